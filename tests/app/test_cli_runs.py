"""The work commands of the CLI: simulate, diagnose FILE, sweep FILE, calibrate."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml
from sqlalchemy import select
from typer.testing import CliRunner

from app.cli import cli
from app.cli_support import estimate_text, store_session
from app.db.models import Diagnosis, PumpSet, ThrottleCalibration
from diagnostics.pump import (
    InstrumentNoise,
    default_levels,
    iso4409_grid,
    run_virtual_bench,
    write_bench_csv,
)
from sim.components.gear_pump_map import stand_in_pump
from tests.app.conftest import store_count
from tests.real_slices import v32hl56_slice, zema_slice

ZEMA_RIG = Path(__file__).resolve().parents[2] / "sim" / "rigs" / "zema.yaml"


def _simulated_summary(runner: CliRunner, *options: str) -> dict[str, Any]:
    result = runner.invoke(cli, ["simulate", "--steady", "--json", *options])
    assert result.exit_code == 0, result.output
    return dict(json.loads(result.stdout)["summary"])


def test_simulate_prints_the_summary_and_writes_the_series(runner: CliRunner,
                                                            tmp_path: Path) -> None:
    table = runner.invoke(cli, ["simulate", "--fault", "worn_spool", "--load", "4200",
                                "--output", str(tmp_path / "run.parquet")])
    assert table.exit_code == 0, table.output
    assert "velocity_ratio [-]" in table.stdout
    # units in brackets are text, not rich markup (issue 12: the CLI showed every unit)
    assert "working.Q_meter_B [m^3/s]" in table.stdout and "working.speed [m/s]" in table.stdout
    frame = pq.read_table(tmp_path / "run.parquet").to_pandas()
    assert list(frame.columns[:2]) == ["t [s]", "phase"] and len(frame) > 100
    worn = _simulated_summary(runner, "--set", "valve.cv=60e-6")
    nominal = _simulated_summary(runner)
    assert worn["working.Q_valve_leak [m^3/s]"] > 3 * nominal["working.Q_valve_leak [m^3/s]"]
    # no fault and no --set is the nominal rig (it was titled "overrides only": a CLI pass)
    plain = runner.invoke(cli, ["simulate", "--steady"], terminal_width=200)
    assert plain.exit_code == 0 and "rig 1 v1, nominal, steady" in plain.stdout, plain.stdout
    bad = runner.invoke(cli, ["simulate", "--set", "valve.cv=-1"])
    # named as the option gave it, not as the API names it (a CLI pass)
    assert bad.exit_code != 0 and bad.exception.field == "--set valve.cv", bad.output


def test_diagnose_a_yaml_file_of_records(runner: CliRunner, tmp_path: Path) -> None:
    s = _simulated_summary(runner, "--set", "valve.cv=60e-6")
    record = {"rig_id": 1, "measured_at": "2026-05-01T10:00:00Z",
              "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
              "pump_pressure": s["working.P_pump [Pa]"], "p1": s["working.P1 [Pa]"],
              "p2": s["working.P2 [Pa]"], "flow_B": s["working.Q_meter_B [m^3/s]"],
              "flow_C": s["working.Q_meter_C [m^3/s]"], "speed_work": s["working.speed [m/s]"],
              "speed_return": s["return.speed [m/s]"]}
    path = tmp_path / "records.yaml"
    # two readings of the same state a minute apart (the same record twice is one
    # measurement: stored once, the second refused)
    path.write_text(yaml.safe_dump([record, record | {"measured_at": "2026-05-01T10:01:00Z"}]))
    result = runner.invoke(cli, ["diagnose", str(path), "--json"])
    assert result.exit_code == 0, result.output
    body = json.loads(result.stdout)
    assert body["mode"] == "each" and [d["top"] for d in body["diagnoses"]] == ["valve"] * 2
    assert store_count(Diagnosis) == 2
    table = runner.invoke(cli, ["diagnose", str(path), "--joint", "--no-store"])
    assert table.exit_code == 0, table.output
    assert "valve" in table.stdout and "not stored" in table.stdout
    # each fitted parameter with its 95 % interval, a factor without a unit of "1"
    joint = json.loads(runner.invoke(cli, ["diagnose", str(path), "--joint", "--no-store",
                                           "--json"]).stdout)["diagnoses"][0]["result"]
    (cv,) = next(f for f in joint["hypotheses"] if f["name"] == "valve")["parameters"]
    flat = " ".join(table.stdout.split())
    # a clearance in µm, as an engineer reads it (was "cv = 6.007e-05 (5.844e-05 … ) m")
    value, interval = estimate_text(1e6 * cv["value"], 1e6 * cv["low"], 1e6 * cv["high"])
    assert f"cv = {value} ({interval}) µm" in flat and 50.0 < float(value) < 70.0
    # a hypothesis that the records push to the healthy end of its worn range says so
    bound = [p for f in joint["hypotheses"] for p in f["parameters"] if p["at_bound"]]
    assert bound and flat.count("at bound") == len(bound) + 1   # each, and the footnote
    assert "at bound: the fit sits on the healthy end of the hypothesis's worn range" in flat
    assert "pump_leak = " in flat and not re.search(r"pump_leak = [^,]*\) 1\b", flat)
    # the two records read by the same instruments: their errors do not average out, so
    # the interval is that of one record, √2 wider (diagnostics/shared_errors.py)
    shared = json.loads(runner.invoke(cli, [
        "diagnose", str(path), "--joint", "--no-store", "--json", "--calibration-share", "1"
    ]).stdout)["diagnoses"][0]["result"]
    (cv_shared,) = next(f for f in shared["hypotheses"] if f["name"] == "valve")["parameters"]
    assert cv_shared["value"] == pytest.approx(cv["value"], rel=1e-12)
    assert cv_shared["high"] - cv_shared["low"] > 1.3 * (cv["high"] - cv["low"])
    over = runner.invoke(cli, ["diagnose", str(path), "--joint", "--calibration-share", "2"])
    assert over.exit_code == 2 and "--calibration-share" in over.output, over.output
    assert store_count(Diagnosis) == 2
    path.write_text(yaml.safe_dump(record | {"flow_C": -1.0}))
    bad = runner.invoke(cli, ["diagnose", str(path)])
    assert bad.exit_code != 0 and getattr(bad.exception, "field", None) == "record.flow_C"


def test_diagnose_says_when_the_name_is_not_a_confident_one(runner: CliRunner,
                                                           tmp_path: Path) -> None:
    """A seal at leakage 1.2 × nominal (below the worn range) read at three loads and
    diagnosed jointly: explained, not a confident name — the table is followed by the
    goodness-of-fit statement (incipient wear, or a document off by that much), which the
    CLI once left out."""
    from sim.rigs import reference_rig
    from tests.diagnostics.synth import FULL, readings

    rig = reference_rig()
    records = []
    for load, temperature in ((2100.0, 35.0), (4200.0, 45.0), (6300.0, 50.0)):
        v = readings(rig, {"cylinder.cc": 83e-6 * 1.2 ** (1 / 3)}, load, temperature)
        records.append({"rig_id": 1, "condition": {"oil_temperature": temperature,
                                                   "load_force": load},
                        **{f: float(v[f]) for f in FULL}})
    path = tmp_path / "records.yaml"
    path.write_text(yaml.safe_dump(records))
    result = runner.invoke(cli, ["diagnose", str(path), "--joint", "--no-store"])
    assert result.exit_code == 0, result.output
    text = " ".join(result.stdout.split())
    assert "caution:" in text and "incipient wear of the cylinder" in text


def test_diagnose_says_when_the_name_is_not_isolated(runner: CliRunner,
                                                     tmp_path: Path) -> None:
    """A worn spool read by the three pressures alone: explained and confident, but six
    hypotheses share the probability (an engineer read `pump` p = 0.30 as the answer); the
    table is followed by the credible set, and the JSON says `isolated: false`."""
    from sim.rigs import reference_rig
    from tests.diagnostics.synth import readings

    v = readings(reference_rig(), {"valve.cv": 59e-6}, 4200.0, 45.0)
    record = {"rig_id": 1, "condition": {"oil_temperature": 45.0, "load_force": 4200.0},
              **{f: float(v[f]) for f in ("pump_pressure", "p1", "p2")}}
    path = tmp_path / "record.yaml"
    path.write_text(yaml.safe_dump(record))
    result = runner.invoke(cli, ["diagnose", str(path), "--no-store"])
    assert result.exit_code == 0, result.output
    text = " ".join(result.stdout.split())
    body = json.loads(runner.invoke(cli, ["diagnose", str(path), "--no-store",
                                          "--json"]).stdout)["diagnoses"][0]["result"]
    assert body["confident"] is True and body["isolated"] is False
    cred = body["isolability"]["credible_set"]
    assert len(cred) > 1 and f"not isolated: {', '.join(cred)} share 95 %" in text
    # and the statements that name what would separate them are printed, not pointed to
    # (a user pass: the line referred to statements only --json showed)
    separating = [s for s in body["isolability"]["statements"] if " vs " in s]
    assert separating and all(" ".join(s.split()) in text for s in separating)


def test_diagnose_shows_no_value_for_a_hypothesis_the_readings_do_not_feel(
        runner: CliRunner, tmp_path: Path) -> None:
    """At 2.1 kN the pump pressure stays far below any relief setting of the prior: its
    row showed `Pset = 2.1e+06 Pa`, read by an engineer as "relief found at 21 bar" on a
    70 bar valve (a user pass); it now shows no value."""
    from sim.rigs import reference_rig
    from tests.diagnostics.synth import readings

    v = readings(reference_rig(), {"valve.cv": 59e-6}, 2100.0, 45.0)
    record = {"rig_id": 1, "condition": {"oil_temperature": 45.0, "load_force": 2100.0},
              **{f: float(v[f]) for f in ("pump_pressure", "p1", "p2", "speed_work",
                                          "speed_return")}}
    path = tmp_path / "record.yaml"
    path.write_text(yaml.safe_dump(record))
    body = json.loads(runner.invoke(cli, ["diagnose", str(path), "--no-store",
                                          "--json"]).stdout)["diagnoses"][0]["result"]
    unfelt = [f["name"] for f in body["hypotheses"] if not f["observable"]]
    assert unfelt == ["relief_setting"]
    shown = runner.invoke(cli, ["diagnose", str(path), "--no-store"], terminal_width=200)
    assert shown.exit_code == 0, shown.output
    row = next(line for line in shown.stdout.splitlines() if "relief_setting " in line)
    assert "not observable" in row and "these readings do not feel it" in row
    assert "Pset" not in row


def test_sweep_writes_the_results_table(runner: CliRunner, tmp_path: Path) -> None:
    spec = tmp_path / "sweep.json"
    spec.write_text(json.dumps({
        "rig_id": 1, "faults": ["healthy", "worn_piston"],
        "parameters": [{"name": "valve.cv", "low": 34e-6, "high": 34e-6, "levels": 1}],
        "conditions": [{"name": "load", "low": 2100.0, "high": 6300.0, "levels": 3}]}))
    result = runner.invoke(cli, ["sweep", str(spec), "--output", str(tmp_path / "out.csv")])
    assert result.exit_code == 0, result.output
    frame = pd.read_csv(tmp_path / "out.csv")
    assert len(frame) == 6
    # every factor with its unit, as the summary columns (they had none: a CLI pass)
    assert list(frame.columns[:3]) == ["fault", "valve.cv [m]", "condition.load [N]"]
    worn = frame[frame["fault"] == "worn_piston"]["working.Q_cyl_leak [m^3/s]"].to_numpy()
    healthy = frame[frame["fault"] == "healthy"]["working.Q_cyl_leak [m^3/s]"].to_numpy()
    assert (worn > 2 * healthy).all()


def test_calibrate_pump_and_throttle(runner: CliRunner, tmp_path: Path) -> None:
    dp, w = iso4409_grid(*default_levels())
    data = run_virtual_bench(stand_in_pump(), dp, w, (22.0, 60.0), noise=InstrumentNoise.none())
    write_bench_csv(data, tmp_path / "bench.csv")
    pump = runner.invoke(cli, ["calibrate", "pump", str(tmp_path / "bench.csv"),
                               "--name", "cli-pump", "--pump", "stand-in gear pump"])
    assert pump.exit_code == 0, pump.output
    assert "Cs_coef" in pump.stdout and store_count(PumpSet) == 1
    # the capacity in cm³/rev and the pressures in bar, as an engineer reads them (the
    # stand-in is a 14.7 cm³/rev pump; D_per_rev was "1.47e-05 m^3/rev")
    flat = " ".join(pump.stdout.split())
    m = re.search(r"D_per_rev │ ([\d.]+) │ cm³/rev", flat)
    assert m and float(m.group(1)) == pytest.approx(14.7, rel=5e-3), flat
    assert re.search(r"dp_range │ [\d.]+ … [\d.]+ │ bar", flat)
    # the bench's oil in its data sheet's unit (cSt); stored in SI with the set; half a
    # pair refused naming the option (a papers pass: an HV VG 46 read with the default's
    # viscosity gave Cs and Cv 14-17 % low, and no option said which oil)
    oiled = runner.invoke(cli, ["calibrate", "pump", str(tmp_path / "bench.csv"), "--name",
                                "cli-pump-hv", "--pump", "stand-in", "--oil-nu40", "46",
                                "--oil-nu100", "8.2", "--oil-rho15", "872"])
    assert oiled.exit_code == 0, oiled.output
    with store_session() as session:
        stored = session.scalars(select(PumpSet).where(PumpSet.name == "cli-pump-hv")).one()
        assert stored.quantities["oil_nu100"]["value"] == pytest.approx(8.2e-6, rel=1e-12)
        assert "the oil stated (46 cSt at 40 °C, 8.2 cSt at 100 °C" in (stored.source or "")
    half = runner.invoke(cli, ["calibrate", "pump", str(tmp_path / "bench.csv"), "--name",
                               "cli-pump-half", "--pump", "stand-in", "--oil-nu40", "46"])
    assert half.exit_code != 0 and getattr(half.exception, "field", None) == "--oil-nu100"
    in_si = runner.invoke(cli, ["calibrate", "pump", str(tmp_path / "bench.csv"), "--name",
                                "cli-pump-si", "--pump", "stand-in", "--oil-nu40", "4.6e-5",
                                "--oil-nu100", "8.2e-6"])
    assert getattr(in_si.exception, "field", None) == "--oil-nu40"
    assert "the option takes cSt" in str(in_si.exception)
    assert store_count(PumpSet) == 2
    table = tmp_path / "table.yaml"
    table.write_text(yaml.safe_dump({
        "throttle": "I", "component": "valve", "back_pressure_pa": 3.0e6,
        "temperature_c": 40.0,
        "points": [{"opening_turns": 0.0, "bypass_flow_m3s": 1.0e-5},
                   {"opening_turns": 1.0, "bypass_flow_m3s": 8.0e-5}]}))
    before = store_count(ThrottleCalibration)
    # the rig is asked for: its default, rig 1, stored a user's table on the paper rig
    # without a word (a rig author's pass)
    unnamed = runner.invoke(cli, ["calibrate", "throttle", str(table)])
    assert unnamed.exit_code != 0 and "--rig" in unnamed.output
    # a CSV table is read as one YAML string: say what the file is (a technician's pass)
    csv = tmp_path / "table.csv"
    csv.write_text("opening_turns,bypass_flow_m3s\n0,8.6e-6\n0.5,1.3e-5\n")
    as_csv = runner.invoke(cli, ["calibrate", "throttle", str(csv), "--rig", "1"])
    assert as_csv.exit_code != 0 and getattr(as_csv.exception, "field", None) == "FILE"
    assert "JSON or YAML body of POST /rigs/{id}/calibrations" in str(as_csv.exception)
    assert store_count(ThrottleCalibration) == before
    throttle = runner.invoke(cli, ["calibrate", "throttle", str(table), "--rig", "1"])
    assert throttle.exit_code == 0, throttle.output
    assert "calibration" in throttle.stdout and "of rig 1" in throttle.stdout
    assert "computed" in throttle.stdout and "clearance [m]" in throttle.stdout
    # the flow in l/min beside m³/s (1e-5 m³/s = 0.6 l/min) and the clearance in µm
    assert "[l/min]" in throttle.stdout and "[µm]" in throttle.stdout
    assert re.search(r"\b1e-05\s+│\s+0\.6\s+│", throttle.stdout), throttle.stdout
    assert store_count(ThrottleCalibration) == before + 1
    original = table.read_text()
    # flows typed in l/min: refused with the field and the pump's delivery, nothing stored
    table.write_text(yaml.safe_dump({
        "throttle": "J", "component": "valve", "back_pressure_pa": 1.0e6,
        "temperature_c": 40.0,
        "points": [{"opening_turns": 0.0, "bypass_flow_m3s": 0.52},
                   {"opening_turns": 1.0, "bypass_flow_m3s": 0.745}]}))
    slip = runner.invoke(cli, ["calibrate", "throttle", str(table), "--rig", "1"])
    assert slip.exit_code != 0
    assert getattr(slip.exception, "field", None) == "points[0].bypass_flow_m3s"
    assert store_count(ThrottleCalibration) == before + 1
    # the tables read back from the CLI too, with their clearances in µm and what
    # computed them (the CLI could only create them: a technician's pass)
    listed = runner.invoke(cli, ["calibrate", "tables", "--rig", "1"])
    assert listed.exit_code == 0, listed.output
    flat = " ".join(listed.stdout.split())
    assert "throttle tables of rig 1" in flat and "34.0," in flat and "26.0, 52.1" in flat
    assert "version 1" in flat and "stale" not in flat and "oil [°C]" in flat
    # one table's rows, as the store keeps them and as a technician reads them (a table
    # could be stored from the CLI but its rows not read back: a technician's pass)
    stored = int(re.search(r"calibration (\d+) of rig 1", throttle.stdout).group(1))
    rows = runner.invoke(cli, ["calibrate", "tables", "--rig", "1", "--table", str(stored)])
    assert rows.exit_code == 0, rows.output
    assert rows.stdout == throttle.stdout          # the table the store command printed
    missing = runner.invoke(cli, ["calibrate", "tables", "--rig", "1", "--table", "999"])
    assert missing.exit_code != 0
    # a duplicate's refusal names the command line's remedy too, which now exists (it
    # named PATCH and DELETE alone: a CLI pass); --refresh computes the rows again
    table.write_text(original)
    twice = runner.invoke(cli, ["calibrate", "throttle", str(table), "--rig", "1"])
    assert twice.exit_code != 0
    assert f"--table {stored} --delete" in " ".join(str(twice.exception).split())
    refreshed = runner.invoke(cli, ["calibrate", "tables", "--rig", "1", "--table",
                                    str(stored), "--refresh"])
    assert refreshed.exit_code == 0 and refreshed.stdout == throttle.stdout, refreshed.output
    alone = runner.invoke(cli, ["calibrate", "tables", "--rig", "1", "--delete"])
    assert getattr(alone.exception, "field", None) == "--delete"
    deleted = runner.invoke(cli, ["calibrate", "tables", "--rig", "1", "--table",
                                  str(stored), "--delete"])
    assert deleted.exit_code == 0, deleted.output
    assert store_count(ThrottleCalibration) == before


def test_calibrate_pump_on_a_real_single_temperature_map(runner: CliRunner, tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    import math

    from diagnostics.pump.levels import cluster_levels
    from diagnostics.pump.piston import bench_frame, read_efficiency_map

    slice_ = v32hl56_slice()
    data = read_efficiency_map(slice_)
    idx, lev = cluster_levels(data.D, field="D")
    big = data.subset(idx == int(lev.argmax()))
    bench_frame(big, 50.0).to_csv(tmp_path / "map.csv", index=False)
    cm3 = float(lev.max()) * 2e6 * math.pi
    result = runner.invoke(cli, ["calibrate", "pump", str(tmp_path / "map.csv"), "--name",
                                 "v32", "--pump", "V32HL56 piston pump",
                                 "--displacement-cm3-rev", f"{cm3:.6f}"])
    assert result.exit_code == 0, result.output
    assert "not identifiable" in result.stdout and "Cs_coef" not in result.stdout
    # the sign-checked loss model is stored with its held-out error and its points
    assert "check_flow_S" in result.stdout and "points_q_held_out" in result.stdout
    assert "checked one speed out" in result.stdout
    assert store_count(PumpSet) == 1
    both = runner.invoke(cli, ["calibrate", "pump", str(tmp_path / "map.csv"), "--name", "v33",
                               "--pump", "x", "--displacement", "1e-6",
                               "--displacement-cm3-rev", "57"])
    assert both.exit_code != 0 and store_count(PumpSet) == 1
    # an error names the option typed (was --displacement, and displacement_m3_rad)
    for value in ("-16", "1.6e-5"):
        wrong = runner.invoke(cli, ["calibrate", "pump", str(tmp_path / "map.csv"), "--name",
                                    "v34", "--pump", "x", "--displacement-cm3-rev", value])
        assert wrong.exit_code != 0
        assert getattr(wrong.exception, "field", None) == "--displacement-cm3-rev", value
    assert store_count(PumpSet) == 1
    monkeypatch.setenv("COLUMNS", "200")
    help_text = runner.invoke(cli, ["calibrate", "pump", "--help"]).stdout
    for unit in ("[m³/rad]", "[cm³/rev]", "[Pa, kPa, bar, MPa]"):
        assert unit in help_text
    # a paragraph of the docstring is one paragraph of help, wrapped by rich, not at the
    # docstring's own line breaks (typer 0.29 kept them: 'p_in, p_out' / '[Pa, kPa, …')
    assert "p_in, p_out [Pa, kPa, bar, MPa], n [rev/s, Hz, rpm, rad/s]" in help_text
    # every unit the reader takes for speed and flow is in the help (Hz, L/min and
    # cm^3/s were accepted but not listed: a pump maker's pass)
    from sim.units import UNITS
    flat = " ".join(help_text.replace("│", " ").split())
    for canonical in ("rad/s", "m^3/s"):
        assert all(spelling in flat for spelling in UNITS[canonical]), canonical
    assert "[rad/s]" in runner.invoke(cli, ["simulate", "--help"]).stdout


def test_import_zema_cycles_and_a_series_file(runner: CliRunner, tmp_path: Path) -> None:
    from app.db.models import MeasuredSeries

    root = zema_slice()
    # ZeMA cycles onto the paper-002 rig: refused, naming the rig option (they were stored,
    # and a bench table written at that rig's 1600 rpm)
    wrong = runner.invoke(cli, ["import", "zema", "--rig", "1", "--root", str(root),
                                "--first", "2", "--last", "5"])
    assert wrong.exit_code != 0 and getattr(wrong.exception, "field", None) == "--rig"
    assert "'pump-relief-orifice'" in str(wrong.exception)
    assert store_count(MeasuredSeries) == 0
    assert runner.invoke(cli, ["rigs", "add", str(ZEMA_RIG)]).exit_code == 0
    result = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                                 "--first", "2", "--last", "5"])
    assert result.exit_code == 0, result.output
    assert "4 ZeMA cycles stored" in result.stdout and store_count(MeasuredSeries) == 4
    # a range overlapping the stored one: refused whole, naming --first, with the way on;
    # one past the data set's end names --last (both read 'cycles', 'name' before)
    overlap = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                                  "--first", "4", "--last", "6"])
    assert getattr(overlap.exception, "field", None) == "--first"
    assert "import only the cycles not stored yet" in str(overlap.exception)
    beyond = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                                 "--first", "6", "--last", "99999"])
    assert getattr(beyond.exception, "field", None) == "--last"
    assert store_count(MeasuredSeries) == 4
    # consecutive 60 s cycles on a clock: cycle k stored (k − 1) minutes after cycle 1's
    # start (every ZeMA cycle was stored without a time; a real-data analyst's pass)
    timed_cycles = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                                       "--first", "6", "--last", "7", "--name", "timed",
                                       "--started-at", "2026-11-20T08:00:00Z"])
    assert timed_cycles.exit_code == 0, timed_cycles.output
    with store_session() as session:
        times = {r.record: r.measured_at for r in session.query(MeasuredSeries)
                 .filter(MeasuredSeries.name == "timed")}
    assert {k: t.isoformat() for k, t in times.items()} == {
        "cycle-6": "2026-11-20T08:05:00+00:00", "cycle-7": "2026-11-20T08:06:00+00:00"}
    assert store_count(MeasuredSeries) == 6
    csv = tmp_path / "s.csv"
    csv.write_text("record,t [s],p_pump [bar],q_work [l/min]\na,0,150,7.9\na,1,151,7.8\n"
                   "b,0,160,7.7\nb,0.5,161,7.6\n")
    result = runner.invoke(cli, ["import", "series", str(csv), "--rig", "1", "--name", "s"])
    assert result.exit_code == 0, result.output
    assert store_count(MeasuredSeries) == 8 and "p_pump [Pa]" in result.stdout
    # other samples (the same ones without a start are the same measurement: refused)
    csv.write_text("record,t [s],p_pump [bar],q_work [l/min]\na,0,152,7.9\na,1,153,7.8\n"
                   "b,0,162,7.7\nb,0.5,163,7.6\n")
    timed = runner.invoke(cli, ["import", "series", str(csv), "--rig", "1", "--name", "t",
                                "--started-at", "2026-11-20T08:00:00Z"])
    assert timed.exit_code == 0, timed.output
    assert timed.stdout.count("2026-11-20 08:00:00") == 2  # b starts at t = 0 as well
    with store_session() as session:
        times = session.scalars(select(MeasuredSeries.measured_at)
                                .where(MeasuredSeries.name == "t")).all()
    assert [w.isoformat() if w else None for w in times] == ["2026-11-20T08:00:00+00:00"] * 2
    naive = runner.invoke(cli, ["import", "series", str(csv), "--rig", "1", "--name", "u",
                                "--started-at", "2026-11-20T08:00:00"])
    assert naive.exit_code != 0 and getattr(naive.exception, "field", None) == "--started-at"
    assert store_count(MeasuredSeries) == 10
    csv.write_text("t [s],p_pump [psi]\n0,1\n1,2\n")
    bad = runner.invoke(cli, ["import", "series", str(csv), "--rig", "1", "--name", "bad"])
    assert bad.exit_code != 0 and store_count(MeasuredSeries) == 10
    assert "[Hz]" in runner.invoke(cli, ["import", "series", "--help"]).stdout


def test_a_loggers_folder_of_compressed_files_is_imported_together(
        runner: CliRunner, tmp_path: Path) -> None:
    """The rotary-actuator recordings as the data set keeps them (gzip, tab-separated raw
    counts, ``tests/real_slices.py``): several files in one import, each record named after
    its file; one bad file among them stores nothing; one start for several files is
    refused."""
    import gzip

    from app.db.models import MeasuredSeries
    from tests.real_slices import vtnsi_slice

    paths = []
    for path in vtnsi_slice():
        packed = tmp_path / (path.name + ".gz")
        packed.write_bytes(gzip.compress(path.read_bytes()))
        paths.append(packed)
    cmap = json.dumps({"PG_1": ["pg1", "-"], "PG_2": ["pg2", "-"], "Angle": ["angle", "-"]}
                      | {c: ["skip", "-"] for c in (
                          "Time", "Accel_1", "Accel_2", "Accel_3", "Temp_1", "Temp_2",
                          "Temp_3", "PG_3", "Lim_1", "Lim_2", "Lim_3", "Internal_Temp",
                          "F_Names", "F_Values", "Prediction")})
    args = ["import", "series", *map(str, paths), "--rig", "1", "--name", "vtnsi",
            "--column-map", cmap, "--sample-rate", "250"]
    bad = tmp_path / "broken.csv"
    bad.write_text("t [s],P1 [psi]\n0,1\n1,2\n")
    refused = runner.invoke(cli, [*args[:4], str(bad), *args[4:]])
    assert refused.exit_code != 0 and "broken.csv" in str(refused.exception)
    assert store_count(MeasuredSeries) == 0  # a fresh store: the two good files not stored
    both = runner.invoke(cli, [*args, "--started-at", "2019-09-10T16:37:01Z"])
    assert both.exit_code != 0 and getattr(both.exception, "field", None) == "--started-at"
    done = runner.invoke(cli, args)
    assert done.exit_code == 0, done.output
    assert store_count(MeasuredSeries) == 2 and "2 files" in done.stdout
    with store_session() as session:
        rows = session.scalars(select(MeasuredSeries).where(MeasuredSeries.name == "vtnsi")
                               .order_by(MeasuredSeries.id)).all()
        assert [r.record for r in rows] == [p.name.removesuffix(".gz") for p in paths]
        assert all(r.n_samples == 400 and r.sample_rate == pytest.approx(250.0) for r in rows)
    # each file's start as the logger wrote it into the name (the data set's local time);
    # the same samples stored without a start are the same measurement: deleted first
    with store_session() as session:
        for row in rows:
            session.delete(session.get(MeasuredSeries, row.id))
        session.commit()
    timed = runner.invoke(cli, [*args[:7], "vtnsi-timed", *args[8:], "--time-in-name",
                                "%m-%d-%Y-%I-%M-%S %p", "--zone", "-04:00"])
    assert timed.exit_code == 0, timed.output
    with store_session() as session:
        times = session.scalars(select(MeasuredSeries.measured_at)
                                .where(MeasuredSeries.name == "vtnsi-timed")
                                .order_by(MeasuredSeries.id)).all()
    assert [w.isoformat() if w else None for w in times] == [
        "2019-09-11T12:55:09+00:00", "2019-09-10T20:37:01+00:00"]  # Base 8:55 AM, Leak 4:37 PM
    for extra, field in ((["--time-in-name", "%m-%d-%Y"], "--time-in-name"),
                         (["--zone", "Z"], "--zone"),
                         (["--time-in-name", "%Y", "--zone", "CET"], "--zone")):
        bad = runner.invoke(cli, [*args, *extra])
        assert bad.exit_code != 0 and getattr(bad.exception, "field", None) == field, extra
    assert store_count(MeasuredSeries) == 2


def test_zema_plateaus_become_a_bench_table_the_workflow_reads(runner: CliRunner,
                                                               tmp_path: Path) -> None:
    """The ZeMA path from the command line: the rig file into the store, the cycles'
    settled plateaus written as a bench table at the stored rig's pump speed, the workflow
    on it.  The slice's 18 cycles mix the three pump-leakage classes — a change of the pump
    between cycles, which no effect of the library is — and the workflow says so."""
    from app.db.models import MeasuredSeries
    from diagnostics.pump import read_bench_csv
    from diagnostics.real.profile import plateau_table
    from diagnostics.real.zema import load_1hz, read_records

    root = zema_slice()
    assert runner.invoke(cli, ["rigs", "add", str(ZEMA_RIG)]).exit_code == 0
    out = tmp_path / "plateaus.csv"
    result = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                                 "--first", "1", "--last", "18", "--bench", str(out),
                                 "--no-store"])
    assert result.exit_code == 0, result.output
    assert "90 settled plateaus of 18 cycles" in result.stdout and "1500 rpm" in result.stdout
    assert store_count(MeasuredSeries) == 0
    data, _ = load_1hz(root, list(range(1, 19)))
    expected = plateau_table(read_records(data), relaxation=3.5).bench(50.0 * math.pi)
    bench = read_bench_csv(out)
    assert not bench.simulated and bench.q == pytest.approx(expected.q, rel=1e-12)
    assert bench.theta == pytest.approx(expected.theta, rel=1e-12)
    found = runner.invoke(cli, ["discover", str(out), "--rig", "2", "--no-store"],
                          env={"COLUMNS": "200"})
    assert found.exit_code == 0, found.output
    # the verdict is the command's result: on stdout (progress on stderr)
    assert "unexplained" in found.stdout and "lack of fit" in found.stdout
    # the same cycles stored with the rig and checked by id: their settled plateaus are the
    # table (a rig without a working/return cycle), the answer the file's, exactly
    stored = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                                 "--first", "1", "--last", "18"])
    assert stored.exit_code == 0, stored.output
    by_file = runner.invoke(cli, ["discover", str(out), "--rig", "2", "--no-store", "--json"])
    by_id = runner.invoke(cli, ["discover", "--series", ",".join(map(str, range(1, 19))),
                                "--rig", "2", "--no-store", "--json"])
    assert by_id.exit_code == 0, by_id.output
    a = json.loads(by_file.stdout[by_file.stdout.index("{"):])
    b = json.loads(by_id.stdout[by_id.stdout.index("{"):])
    assert b["verdict"] == a["verdict"] == "unexplained"
    assert b["gap_before"] == a["gap_before"] and b["lack_of_fit"] == a["lack_of_fit"]
    # two cycles are ten plateaus, too few: the error names the option the data came from
    few = runner.invoke(cli, ["discover", "--series", "1,2", "--rig", "2", "--no-store"])
    assert few.exit_code != 0 and str(few.exception).startswith("--series: 10 rows leave")
    bad = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                              "--relaxation", "-1", "--bench", str(out)])
    assert bad.exit_code != 0 and "--relaxation" in str(bad.exception)
    idle = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                               "--no-store"])
    assert idle.exit_code != 0 and "nothing to do" in str(idle.exception)


def test_simulate_samples_at_a_rate_and_reports_its_error(runner: CliRunner,
                                                          tmp_path: Path) -> None:
    out = tmp_path / "run.csv"
    result = runner.invoke(cli, ["simulate", "--sample-rate", "1000", "--output", str(out)])
    assert result.exit_code == 0, result.output
    assert "error estimate v [σ]" in result.stdout
    frame = pd.read_csv(out, comment="#")
    assert frame["t [s]"].diff().dropna().round(12).eq(1e-3).all()
    ros2 = runner.invoke(cli, ["simulate", "--solver", "ros2", "--sample-rate", "1000"])
    assert ros2.exit_code != 0 and "--sample-rate" in str(ros2.exception)


def test_diagnose_a_measured_cycle_file_and_a_stored_one(runner: CliRunner,
                                                          tmp_path: Path) -> None:
    """A cycle in the /simulate export's format is read as the rig's meters read it
    (GET /series/{id}/record) and diagnosed; the same cycle stored, by --series."""
    cycle = tmp_path / "cycle.csv"
    made = runner.invoke(cli, ["simulate", "--fault", "worn_spool", "--load", "4200",
                               "--sample-rate", "1000", "--output", str(cycle)])
    assert made.exit_code == 0, made.output
    result = runner.invoke(cli, ["diagnose", str(cycle), "--rig", "1", "--no-store", "--json"])
    assert result.exit_code == 0, result.output
    [answer] = json.loads(result.stdout)["diagnoses"]
    assert answer["top"] == "valve" and answer["id"] is None
    assert store_count(Diagnosis) == 0
    imported = runner.invoke(cli, ["import", "series", str(cycle), "--rig", "1",
                                   "--name", "cycle"])
    assert imported.exit_code == 0, imported.output
    stored = runner.invoke(cli, ["diagnose", "--series", "1", "--condition",
                                 "oil_temperature=40"])
    assert stored.exit_code == 0, stored.output
    assert "valve (p = " in stored.stdout and store_count(Diagnosis) == 1
    for args, field in ((["diagnose", str(cycle)], "--rig"),
                        (["diagnose", "--series", "1", "--condition", "oil=40"],
                         "condition.oil"),
                        (["diagnose", "--series", "1,x"], "--series"),
                        (["diagnose", str(cycle), "--series", "1"], "FILE"),
                        (["diagnose", "--series", "99"], "series_id")):
        bad = runner.invoke(cli, args)
        assert bad.exit_code != 0 and getattr(bad.exception, "field", None) == field, args
        if field == "condition.oil":   # which of the series (a CLI pass: it was not said)
            assert bad.exception.message.startswith("series 1: "), bad.exception.message
    assert store_count(Diagnosis) == 1
    # the same cycle as a logger writes it: its own names and units, ';' and decimal
    # commas, the spool command for the phase, time in ms, no header: read through a
    # column map, the condition stated, it is the same diagnosis
    frame = pd.read_csv(cycle, comment="#")
    logger = pd.DataFrame({
        "time": frame["t [s]"] * 1e3, "spool": frame["phase"].map({"working": 1, "return": -1}),
        "pos": frame["x [m]"] * 1e3, "PP": frame["P_pump [Pa]"] / 1e5,
        "PA": frame["P1 [Pa]"] / 1e5, "PB": frame["P2 [Pa]"] / 1e5,
        "QB": frame["Q_meter_B [m^3/s]"] * 6e4, "QC": frame["Q_meter_C [m^3/s]"] * 6e4,
        "QR": frame["Q_relief [m^3/s]"] * 6e4, "remark": "ok"})
    logged = tmp_path / "logger.csv"
    logger.to_csv(logged, sep=";", decimal=",", index=False, float_format="%.12g")
    cmap = json.dumps({"time": ["t", "ms"], "spool": ["phase", "-"], "pos": ["x", "mm"],
                       "PP": ["P_pump", "bar"], "PA": ["P1", "bar"], "PB": ["P2", "bar"],
                       "QB": ["Q_meter_B", "l/min"], "QC": ["Q_meter_C", "l/min"],
                       "QR": ["Q_relief", "l/min"], "remark": ["skip", "-"]})
    again = runner.invoke(cli, ["diagnose", str(logged), "--rig", "1", "--column-map", cmap,
                                "--condition", "oil_temperature=40", "--condition",
                                "load_force=4200", "--started-at", "2026-11-20T08:00:00Z",
                                "--no-store", "--json"])
    assert again.exit_code == 0, again.output
    [same] = json.loads(again.stdout)["diagnoses"]
    assert same["top"] == answer["top"] == "valve"
    assert same["probability"] == pytest.approx(answer["probability"], abs=1e-6)
    for args, field in ((["diagnose", "--series", "1", "--column-map", cmap], "--column-map"),
                        (["diagnose", str(logged), "--rig", "1", "--sample-rate", "0"],
                         "--sample-rate"),
                        (["diagnose", str(logged), "--rig", "1", "--column-map", "[1]"],
                         "--column-map")):
        bad = runner.invoke(cli, args)
        assert bad.exit_code != 0 and getattr(bad.exception, "field", None) == field, args
    # the import's checks of the same file and map (a CLI pass): a misspelt channel is
    # named, bar on a flow is refused, a rate the time column contradicts is said
    typo = runner.invoke(cli, ["diagnose", str(logged), "--rig", "1", "--column-map",
                               cmap.replace('"P1"', '"Pressure1"'), "--condition",
                               "oil_temperature=40", "--condition", "load_force=4200",
                               "--no-store"])
    assert typo.exit_code == 0, typo.output
    assert "channel(s) Pressure1 are not channels of the rig's model" in typo.stdout
    # said once, for the file, though each cycle's readings carry it too (a library pass)
    assert typo.stdout.count("Pressure1 are not channels") == 1, typo.stdout
    assert "not read (a cycle's readings are taken from" in " ".join(typo.stdout.split())
    unit = runner.invoke(cli, ["diagnose", str(logged), "--rig", "1", "--column-map",
                               cmap.replace('["Q_meter_B", "l/min"]', '["Q_meter_B", "bar"]'),
                               "--condition", "oil_temperature=40", "--no-store"])
    assert unit.exit_code != 0 and "not a unit of this channel" in str(unit.exception)
    rate = runner.invoke(cli, ["diagnose", str(cycle), "--rig", "1", "--sample-rate", "100",
                               "--condition", "oil_temperature=40", "--no-store"])
    assert rate.exit_code == 0, rate.output
    assert "is not what its time column reads" in rate.stdout
    # with --json the notes go beside it, the JSON stays parseable (a verification pass)
    as_json = runner.invoke(cli, ["diagnose", str(cycle), "--rig", "1", "--sample-rate",
                                  "100", "--condition", "oil_temperature=40", "--no-store",
                                  "--json"])
    assert as_json.exit_code == 0, as_json.output
    assert "is not what its time column reads" in as_json.stderr
    json.loads(as_json.stdout)
    assert store_count(Diagnosis) == 1


def test_diagnose_a_file_of_several_cycles_each_or_jointly(runner: CliRunner,
                                                            tmp_path: Path) -> None:
    """Two cycles of one worn spool at two loads in one Parquet table (a ``record`` column):
    each is read and diagnosed on its own, or both together with --joint."""
    frames = []
    for load in ("2100", "4200"):
        out = tmp_path / f"c{load}.parquet"
        made = runner.invoke(cli, ["simulate", "--fault", "worn_spool", "--load", load,
                                   "--sample-rate", "500", "--output", str(out)])
        assert made.exit_code == 0, made.output
        frames.append(pq.read_table(out).to_pandas().assign(record=f"load-{load}"))
    both = tmp_path / "visit.parquet"
    pd.concat(frames).to_parquet(both)
    each = runner.invoke(cli, ["diagnose", str(both), "--rig", "1", "--no-store", "--json"])
    assert each.exit_code == 0, each.output
    answers = json.loads(each.stdout)["diagnoses"]
    assert [a["top"] for a in answers] == ["valve", "valve"]
    joint = runner.invoke(cli, ["diagnose", str(both), "--rig", "1", "--no-store", "--json",
                                "--joint"])
    assert joint.exit_code == 0, joint.output
    [answer] = json.loads(joint.stdout)["diagnoses"]
    assert answer["top"] == "valve" and len(answer["records"]) == 2


def test_a_record_without_readings_is_refused_naming_the_record(runner: CliRunner,
                                                                tmp_path: Path) -> None:
    """Its field read `record.record` (a user pass): the record itself is at fault."""
    path = tmp_path / "empty.json"
    path.write_text(json.dumps({"rig_id": 1, "condition": {"oil_temperature": 40.0,
                                                           "load_force": 4200.0}}))
    refused = runner.invoke(cli, ["diagnose", str(path), "--no-store"])
    assert refused.exit_code != 0
    assert getattr(refused.exception, "field", None) == "record"   # the request's path
    assert "no quantity a diagnosis can use" in str(refused.exception)


def test_a_record_that_can_see_no_fault_is_said_so(runner: CliRunner, tmp_path: Path) -> None:
    """The CLI headlined such a record "healthy (p = 1.000)" with a caution that the
    readings are "consistent with healthy", and never printed that nothing was seen (a
    verification pass)."""
    from diagnostics.diagnose import BLIND_NOTE

    path = tmp_path / "vague.yaml"
    path.write_text("rig_id: 1\ncondition: {oil_temperature: 40.0, load_force: 2100.0}\n"
                    "speed_work: {value: 0.2064, u: 0.3}\n")
    done = runner.invoke(cli, ["diagnose", str(path), "--no-store"])
    assert done.exit_code == 0, done.output
    assert "caution:" in done.stdout
    assert " ".join(BLIND_NOTE.split()) in " ".join(done.stdout.split())
