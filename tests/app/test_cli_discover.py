"""``hydrodiag discover``: the workflow from the command line, with the report files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from app.cli import cli
from diagnostics.discrepancy.synthetic import synthesize
from sim.errors import InputError
from sim.rigs import load_rig, reference_rig_document
from sim.rigs.assembly import Condition


def _data(path: Path) -> Path:
    doc = reference_rig_document()
    doc["effects"] = {"seal_friction_pressure": {"parameters": {
        "k_p": {"value": 1.5e-5, "unit": "m^2"}}}}
    rig = load_rig(doc)
    rng = np.random.default_rng(5)
    frames = []
    for load, temp in ((2100.0, 40.0), (4200.0, 50.0), (6300.0, 60.0)):
        rec = synthesize(rig, Condition(load=load, oil_temperature=temp), rng=rng)
        f = rec.frame()
        f.insert(0, "record", f"load-{load:.0f}")
        f["load [N]"] = load
        f["oil_temperature [degC]"] = temp
        frames.append(f)
    pd.concat(frames).to_csv(path, index=False)
    return path


def test_discover_names_the_effect_stores_a_version_and_writes_the_report(
        runner: CliRunner, tmp_path: Path) -> None:
    data = _data(tmp_path / "cycles.csv")
    out = tmp_path / "report.html"
    result = runner.invoke(cli, ["discover", str(data), "--rig", "1", "--report", str(out),
                                 "--json"])
    assert result.exit_code == 0, result.output
    body = json.loads(result.output[result.output.index("{"):])
    assert [n["name"] for n in body["named"]] == ["seal_friction_pressure"]
    assert body["new_rig_version"] == 2
    assert (body["rig_id"], body["rig_version"]) == (1, 1)   # were null (a modelling pass)
    page = out.read_text()
    assert "seal_friction_pressure" in page and "<svg" in page
    assert "Checked against rig 1 version 1; the named effect is stored as version 2" in page
    assert (tmp_path / "report_residual_vs_time.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "report_model_vs_measurement.svg").exists()
    bad = tmp_path / "bad.csv"
    pd.read_csv(data).rename(columns={"P2 [Pa]": "P2 [parsec]"}).to_csv(bad, index=False)
    failed = runner.invoke(cli, ["discover", str(bad), "--rig", "1"])
    assert failed.exit_code != 0
    assert "P2 [parsec]" in str(failed.exception) + failed.output


def test_discover_runs_on_records_stored_by_import(runner: CliRunner, tmp_path: Path) -> None:
    data = _data(tmp_path / "cycles.csv")
    from_file = runner.invoke(cli, ["discover", str(data), "--rig", "1", "--no-store", "--json"])
    assert from_file.exit_code == 0, from_file.output
    imported = runner.invoke(cli, ["import", "series", str(data), "--rig", "1", "--name", "c"])
    assert imported.exit_code == 0, imported.output
    # stored with their phases and conditions, the records give the workflow's answer exactly
    stored = runner.invoke(cli, ["discover", "--series", "1,2,3", "--rig", "1", "--no-store",
                                 "--json"])
    assert stored.exit_code == 0, stored.output
    a = json.loads(from_file.output[from_file.output.index("{"):])
    b = json.loads(stored.output[stored.output.index("{"):])
    assert [n["name"] for n in b["named"]] == ["seal_friction_pressure"]
    assert b["named"][0]["value"] == a["named"][0]["value"]
    assert b["held_out_records"] == a["held_out_records"] == ["load-6300"]
    for args, field in ((["--series", "1,x"], "--series"), ([str(data), "--series", "1"], "--series"),
                        (["--series", "1", "--relaxation", "-1"], "--relaxation"),
                        (["--series", ",".join(["1"] * 201)], "--series"),
                        ([], "data"), (["--series", "1,1"], "--series")):
        bad = runner.invoke(cli, ["discover", *args, "--rig", "1"])
        assert bad.exit_code != 0 and field in str(bad.exception), (args, bad.exception)
        assert isinstance(bad.exception, InputError), (args, bad.exception)  # exit 1, a message


def test_discover_reads_a_pump_bench_table(runner: CliRunner, tmp_path: Path) -> None:
    from diagnostics.discrepancy.synthetic import synthesize_bench
    from diagnostics.pump.csvio import write_bench_csv
    from sim.rigs import reference_rig

    path = tmp_path / "bench.csv"
    write_bench_csv(synthesize_bench(reference_rig(), rng=np.random.default_rng(8),
                                     effects={"speed_offset": 1.0}), path)
    out = tmp_path / "bench.html"
    result = runner.invoke(cli, ["discover", str(path), "--rig", "1", "--no-store",
                                 "--report", str(out), "--json"])
    assert result.exit_code == 0, result.output
    body = json.loads(result.output[result.output.index("{"):])
    assert [n["name"] for n in body["named"]] == ["speed_offset"]
    assert body["new_rig_version"] is None
    assert "speed_offset" in out.read_text()
    bad = tmp_path / "bad.csv"
    bad.write_text(path.read_text().replace("n [rev/s]", "n [parsec]"))
    failed = runner.invoke(cli, ["discover", str(bad), "--rig", "1"])
    assert failed.exit_code != 0
    assert "n [parsec]" in str(failed.exception) + failed.output


def test_what_would_damage_the_rig_is_reported_and_not_stored(runner: CliRunner,
                                                              tmp_path: Path) -> None:
    """A user pass stored (1) a version built on version 1 as the latest, dropping the effect
    version 2 had added, and (2) a bench of another pump as rig 1's pump (17.5 → 57
    cm³/rev).  Neither is stored now; the answer says why, and the store is unchanged."""
    from diagnostics.discrepancy.synthetic import synthesize_bench
    from diagnostics.pump.csvio import write_bench_csv
    from sim.rigs import reference_rig

    data = _data(tmp_path / "cycles.csv")
    first = runner.invoke(cli, ["discover", str(data), "--rig", "1", "--json"])
    assert json.loads(first.output[first.output.index("{"):])["new_rig_version"] == 2
    again = runner.invoke(cli, ["discover", str(data), "--rig", "1", "--version", "1",
                                "--json"])
    assert again.exit_code == 0, again.output
    body = json.loads(again.output[again.output.index("{"):])
    assert body["named"] and body["new_rig_version"] is None
    assert "ran on version 1 and the rig's latest is 2" in body["not_stored"]
    rig = reference_rig()
    other = tmp_path / "other-pump.csv"
    write_bench_csv(synthesize_bench(rig, rng=np.random.default_rng(8), effects={
        "speed_offset": 1.0}, overrides={"pump.Vp": 3 * rig.values()["pump.Vp"]}), other)
    bench = runner.invoke(cli, ["discover", str(other), "--rig", "1"])
    assert bench.exit_code == 0, bench.output
    flat = " ".join(bench.output.split())
    assert "not stored: the re-fit moves pump.Vp by +200 %" in flat
    # (3) an effect the report itself marks implausible: a speed reading 30 rad/s off
    far = tmp_path / "far-off.csv"
    write_bench_csv(synthesize_bench(rig, rng=np.random.default_rng(8), effects={
        "speed_offset": 30.0}), far)
    implausible = runner.invoke(cli, ["discover", str(far), "--rig", "1", "--json"])
    body = json.loads(implausible.output[implausible.output.index("{"):])
    assert [(n["name"], n["plausible"]) for n in body["named"]] == [("speed_offset", False)]
    assert body["new_rig_version"] is None
    assert body["not_stored"].startswith("not stored: outside its plausible range: speed_offset")
    from app.cli_support import store_session
    from app.services.rigs import get_rig

    with store_session() as session:
        assert get_rig(session, 1).latest_version == 2


def test_discover_reads_a_loggers_layout_through_a_column_map(runner: CliRunner,
                                                               tmp_path: Path) -> None:
    """A logger's file (its own column names, ms, bar) had to be imported before it could be
    checked; with --column-map it is checked as the export is, to the same answer."""
    data = _data(tmp_path / "cycles.csv")
    frame = pd.read_csv(data)
    logger = pd.DataFrame({
        "run": frame["record"], "time_ms": frame["t [s]"] * 1e3, "valve": frame["phase"],
        "pos_mm": frame["x [m]"] * 1e3, "vel": frame["v [m/s]"],
        "PA": frame["P1 [Pa]"] / 1e5, "PB": frame["P2 [Pa]"] / 1e5,
        "PP": frame["P_pump [Pa]"] / 1e5, "PV": frame["P_valve_P [Pa]"] / 1e5,
        "QB": frame["Q_meter_B [m^3/s]"] * 6e4, "QC": frame["Q_meter_C [m^3/s]"] * 6e4,
        "F": frame["load [N]"], "T": frame["oil_temperature [degC]"]})
    path = tmp_path / "logger.csv"
    logger.to_csv(path, index=False)
    cmap = json.dumps({"run": ["record", "-"], "time_ms": ["t", "ms"], "valve": ["phase", "-"],
                       "pos_mm": ["x", "mm"], "vel": ["v", "m/s"], "PA": ["P1", "bar"],
                       "PB": ["P2", "bar"], "PP": ["P_pump", "bar"], "PV": ["P_valve_P", "bar"],
                       "QB": ["Q_meter_B", "L/min"], "QC": ["Q_meter_C", "L/min"],
                       "F": ["load", "N"], "T": ["oil_temperature", "degC"]})
    a = runner.invoke(cli, ["discover", str(data), "--rig", "1", "--no-store", "--json"])
    b = runner.invoke(cli, ["discover", str(path), "--rig", "1", "--no-store", "--json",
                            "--column-map", cmap])
    assert b.exit_code == 0, b.output
    first = json.loads(a.output[a.output.index("{"):])
    mapped = json.loads(b.output[b.output.index("{"):])
    assert [n["name"] for n in mapped["named"]] == ["seal_friction_pressure"]
    assert mapped["named"][0]["value"] == pytest.approx(first["named"][0]["value"], rel=1e-3)
    wrong = runner.invoke(cli, ["discover", str(path), "--rig", "1", "--no-store",
                                "--column-map", cmap.replace('["P1", "bar"]', '["P1", "L/min"]')])
    assert wrong.exit_code != 0 and getattr(wrong.exception, "field", None) == "PA"
    stored = runner.invoke(cli, ["discover", "--series", "1", "--rig", "1", "--column-map", cmap])
    assert getattr(stored.exception, "field", None) == "--column-map"


def test_a_partially_explained_discovery_is_not_stored(runner: CliRunner) -> None:
    """Effects that leave a gap may stand for a cause outside the library: a thermometer
    3 K low was "explained" by two piston-leak laws and stored as the rig's next version,
    which every later diagnosis used (a simulation engineer's pass)."""
    import dataclasses

    from app.cli_support import store_session
    from app.services.discrepancy import store_discovery
    from app.services.rigs import get_rig, latest_version
    from diagnostics.discrepancy.steady import discover_steady
    from diagnostics.discrepancy.synthetic import synthesize_bench
    from sim.rigs import reference_rig

    bench = synthesize_bench(reference_rig(), rng=np.random.default_rng(8),
                             effects={"speed_offset": 1.0})
    with store_session() as session:
        document = dict(latest_version(session, get_rig(session, 1)).document)
        found = discover_steady(document, bench, bootstrap=5)
        assert found.verdict == "named" and found.named
        partial = dataclasses.replace(found, verdict="partially explained")
        version, why = store_discovery(session, 1, 1, partial)
        assert version is None and why is not None
        assert "partially explained: the named effects leave a gap" in why
        assert "stated oil temperature" in why
        assert get_rig(session, 1).latest_version == 1


def test_the_base_drift_table_shows_a_clearance_in_micrometres() -> None:
    """A worn piston's re-fitted clearance reads "83 → 119.7 µm", not "8.3e-05 m"; a
    resistance stays in its SI unit; a parameter without an error shows no interval."""
    import re

    from rich.console import Console

    from app.cli_discover import drift_table
    from diagnostics.discrepancy.drift import BaseDrift

    rows = [BaseDrift("cylinder.cc", "m", "seal wear", 83e-6, 119.7e-6, 1.2e-6),
            BaseDrift("pump.Rlp", "Pa*s/m^3", "pump wear", 3.0e11, 1.0e11, float("nan"))]
    out = Console(width=200, record=True)
    out.print(drift_table(rows, ["friction.Fu"]))
    text = re.sub(r"\s+", " ", out.export_text())
    assert re.search(r"cylinder\.cc \[µm\] │ 83 │ 119\.7 │ \+44\.2 % │ "
                     r"117\.3(\d*) … 122\.(\d*)", text), text
    assert re.search(r"pump\.Rlp \[Pa\*s/m\^3\] │ 3e\+11 │ 1e\+11 │ -66\.7 % n\.s\. │ —",
                     text), text
    assert "friction.Fu" in text and "kept as stored" in text
