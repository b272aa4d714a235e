"""Importing measured time series: the /simulate export reads back; bad tables name the column."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from diagnostics.timeseries import SeriesRecord, read_series, series_from_frame
from sim.cycle import run_cycle
from sim.errors import InputError
from sim.rigs import Condition, reference_rig


@pytest.fixture(scope="module")
def cycle():
    rig = reference_rig()
    return run_cycle(rig, {"valve.cv": 50e-6}, Condition(load=4.2e3, oil_temperature=45.0))


def _export_csv(cycle, condition: dict) -> bytes:
    """The /simulate CSV layout: '# key = json' header lines, then the table."""
    import json

    head = f"# rig = \"paper002-reference\"\n# condition = {json.dumps(condition)}\n"
    return (head + cycle.timeseries.to_csv(index=False, float_format="%.17g")).encode()


def test_a_simulate_export_reads_back_exactly_in_si(cycle):
    raw = _export_csv(cycle, {"load": 4200.0, "back_pressure": 0.0, "oil_temperature": 45.0,
                              "pump_speed": None})
    (rec,) = read_series(raw)
    ts = cycle.timeseries
    assert rec.measured
    np.testing.assert_array_equal(rec.t, ts["t [s]"].to_numpy())
    np.testing.assert_array_equal(rec.channel("P_pump"), ts["P_pump [Pa]"].to_numpy())
    np.testing.assert_array_equal(rec.channel("Q_meter_B"), ts["Q_meter_B [m^3/s]"].to_numpy())
    assert rec.units["Q_meter_B"] == "m^3/s"
    assert list(np.unique(rec.phase)) == ["return", "working"]
    assert rec.condition == {"load": 4200.0, "back_pressure": 0.0, "oil_temperature": 45.0}
    assert rec.metadata["rig"] == "paper002-reference"
    # and the record writes itself back in the same format
    again = series_from_frame(rec.frame())[0]
    np.testing.assert_array_equal(again.channel("v"), rec.channel("v"))
    # with its condition: written as constant columns, read back as the condition
    assert again.condition == rec.condition
    assert set(again.channels) == set(rec.channels) | {"oil_temperature"}  # logged as well


def test_parquet_with_metadata_reads_back(tmp_path, cycle):
    import json

    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(cycle.timeseries, preserve_index=False)
    meta = {b"hydrodiag": json.dumps({"condition": {"load": 4200.0}}).encode()}
    pq.write_table(table.replace_schema_metadata(meta), tmp_path / "run.parquet")
    (rec,) = read_series(tmp_path / "run.parquet")
    assert rec.condition == {"load": 4200.0}
    np.testing.assert_array_equal(rec.channel("P1"), cycle.timeseries["P1 [Pa]"].to_numpy())


def test_units_are_converted_and_records_are_split():
    t = np.arange(0.0, 1.0, 0.01)
    frame = pd.DataFrame({
        "record": ["a"] * t.size + ["b"] * t.size,
        "t [ms]": np.concatenate([t, t]) * 1e3,
        "P_pump [bar]": np.concatenate([np.full(t.size, 150.0), np.full(t.size, 160.0)]),
        "Q [l/min]": np.concatenate([np.full(t.size, 7.8), np.full(t.size, 7.6)]),
        "oil_temperature [K]": np.concatenate([np.full(t.size, 313.15), np.full(t.size, 323.15)]),
        "load [kN]": np.concatenate([np.full(t.size, 2.1), np.full(t.size, 4.2)]),
    })
    a, b = series_from_frame(frame)
    assert (a.name, b.name) == ("a", "b")
    assert a.sample_rate == pytest.approx(100.0)
    assert a.channel("P_pump")[0] == pytest.approx(150e5)
    # a logger's times written to the millisecond: exactly its rate, not 999.99999999 Hz
    logged = np.array([float(f"{i / 1000:.3f}") for i in range(400_000)])
    assert np.median(np.diff(logged)) != 1e-3
    assert SeriesRecord("logged", logged, {}, {}).sample_rate == 1000.0
    assert b.channel("Q")[0] == pytest.approx(7.6e-3 / 60)
    assert a.condition == pytest.approx({"oil_temperature": 40.0, "load": 2100.0})
    assert b.condition["load"] == pytest.approx(4200.0)
    assert "load" not in a.channels  # a constant condition is not a channel


def test_a_column_map_adapts_a_foreign_table():
    frame = pd.DataFrame({"time": [0.0, 1.0, 2.0], "PS1": [150.0, 151.0, 152.0]})
    (rec,) = series_from_frame(frame, column_map={"time": ("t", "s"), "PS1": ("P_pump", "bar")})
    np.testing.assert_allclose(rec.channel("P_pump"), [150e5, 151e5, 152e5])


def test_a_loggers_own_record_and_stroke_columns_map_to_the_labels():
    """A user pass: a logger's 'run' and 'stroke' columns could not be mapped ('a value is
    not a number'); they map to the labels, with its units converted and the condition
    read from its own columns."""
    frame = pd.DataFrame({"run": ["a", "a", "a", "b", "b"], "ms": [0.0, 1.0, 2.0, 0.0, 1.0],
                          "stroke": ["working", "working", "return", "working", "return"],
                          "q": [30.0, 30.0, -30.0, 15.0, -15.0], "F": [4.2] * 3 + [2.1] * 2})
    cmap = {"run": ("record", "-"), "stroke": ("phase", ""), "ms": ("t", "ms"),
            "q": ("Q_meter_B", "L/min"), "F": ("load", "kN")}
    a, b = series_from_frame(frame, column_map=cmap)
    assert (a.name, b.name) == ("a", "b")
    np.testing.assert_allclose(a.t, [0.0, 1e-3, 2e-3])
    np.testing.assert_allclose(b.channel("Q_meter_B"), [2.5e-4, -2.5e-4])
    assert a.phase is not None and list(a.phase) == ["working", "working", "return"]
    assert a.condition == {"load": 4200.0} and b.condition == {"load": 2100.0}
    with pytest.raises(InputError, match="label column") as err:
        series_from_frame(frame, column_map=cmap | {"run": ("record", "s")})
    assert err.value.field == "run"
    with pytest.raises(InputError, match="'record', '-'") as err:
        series_from_frame(frame, column_map={k: v for k, v in cmap.items() if k != "run"})
    assert err.value.field == "run"


@pytest.mark.parametrize(
    ("frame", "field", "words"),
    [
        (pd.DataFrame({"t [s]": [0.0, 1.0], "P1": [1.0, 2.0]}), "P1", "unit in brackets"),
        (pd.DataFrame({"t [s]": [0.0, 1.0], "X [furlong]": [1.0, 2.0]}), "X [furlong]",
         "unknown unit"),
        (pd.DataFrame({"t [s]": [0.0, 1.0], "P1 [m/s]": [1.0, 2.0]}), "P1 [m/s]",
         "not a unit of this channel"),
        (pd.DataFrame({"t [s]": [0.0, 1.0, 0.5], "P1 [Pa]": [1.0, 2.0, 3.0]}), "t [s]",
         "does not increase"),
        (pd.DataFrame({"t [s]": [0.0, 1.0], "P1 [Pa]": [1.0, np.nan]}), "P1 [Pa]", "NaN"),
        (pd.DataFrame({"P1 [Pa]": [1.0, 2.0]}), "t", "no time column"),
        (pd.DataFrame({"t [s]": [0.0, 1.0], "v [m/s]": [1.0, 2.0]}), "P1", "missing"),
        # 40 °C written under [K] read −233 °C (a modelling engineer's pass)
        (pd.DataFrame({"t [s]": [0.0, 1.0], "P1 [Pa]": [1.0, 2.0],
                       "oil_temperature [K]": [40.0, 40.0]}), "oil_temperature [K]",
         "is it in °C under a [K] label"),
        (pd.DataFrame({"t [s]": [0.0, 1.0], "P1 [Pa]": [1.0, 2.0],
                       "oil_temperature [degC]": [313.0, 313.0]}), "oil_temperature [degC]",
         "K (or °F) under a [degC] label"),
    ],
)
def test_bad_tables_name_the_column(frame, field, words):
    with pytest.raises(InputError) as exc:
        series_from_frame(frame, expected={"P1": "Pa"}, required=("P1",))
    assert exc.value.field == field
    assert words in exc.value.message


def test_unreadable_files_are_input_errors(tmp_path):
    bad = tmp_path / "x.csv"
    bad.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(InputError):
        read_series(bad)
    with pytest.raises(InputError):
        read_series(b"PAR1 not really parquet", format="parquet")


def test_the_clock_time_of_each_record(tmp_path, cycle):
    """``started_at`` (the keyword, else the header) is the time at t = 0; a record's
    ``measured_at`` adds its first sample's t; windows keep the clock; a Parquet file's
    metadata carries the start as the CSV header does."""
    import json
    from datetime import UTC, datetime

    import pyarrow as pa
    import pyarrow.parquet as pq

    frame = pd.DataFrame({"t [s]": [0.0, 1.0, 3600.0, 3601.0], "record": ["a", "a", "b", "b"],
                          "P1 [bar]": [1.0, 2.0, 3.0, 4.0]})
    text = frame.to_csv(index=False).encode()
    a, b = read_series(b'# started_at = "2026-11-20T09:00:00+01:00"\n' + text)
    assert a.started_at == b.started_at == datetime(2026, 11, 20, 8, tzinfo=UTC)
    assert a.measured_at == datetime(2026, 11, 20, 8, tzinfo=UTC)
    assert b.measured_at == datetime(2026, 11, 20, 9, tzinfo=UTC)
    assert b.window(3600.5, 3601.0).measured_at == datetime(2026, 11, 20, 9, 0, 1, tzinfo=UTC)
    given = datetime(2027, 1, 1, tzinfo=UTC)
    assert read_series(b'# started_at = "2026-11-20T09:00:00Z"\n' + text,
                       started_at=given)[0].measured_at == given
    assert read_series(text)[0].measured_at is None
    table = pa.Table.from_pandas(cycle.timeseries, preserve_index=False)
    meta = {b"hydrodiag": json.dumps({"started_at": "2026-11-20T08:00:00Z"}).encode()}
    pq.write_table(table.replace_schema_metadata(meta), tmp_path / "run.parquet")
    (rec,) = read_series(tmp_path / "run.parquet")
    assert rec.measured_at == datetime(2026, 11, 20, 8, tzinfo=UTC)


@pytest.mark.parametrize("start", ['"2026-11-20T08:00:00"', '"monday"', "1763625600"])
def test_a_start_without_its_zone_is_refused(start):
    with pytest.raises(InputError) as err:
        read_series(f"# started_at = {start}\nt [s],P1 [bar]\n0,1\n1,2\n".encode())
    assert err.value.field == "started_at"



def test_a_raw_signal_reads_through_its_calibration_and_columns_are_skipped():
    """[channel, unit, gain, offset] reads gain·raw + offset in the unit: a 4-20 mA
    transducer of 0-250 bar, a sample index at 500 Hz; [skip, -] leaves a column out."""
    frame = pd.DataFrame({"n": [1, 2, 3], "PT1": [4.0, 12.0, 20.0], "note": ["a", "b", "c"]})
    (rec,) = series_from_frame(frame, column_map={
        "n": ("t", "s", 0.002, -0.002), "PT1": ("P1", "bar", 15.625, -62.5),
        "note": ("skip", "-")})
    np.testing.assert_allclose(rec.t, [0.0, 0.002, 0.004])
    np.testing.assert_allclose(rec.channel("P1"), [0.0, 125e5, 250e5])
    assert set(rec.channels) == {"P1"} and rec.units["P1"] == "Pa"
    # a calibrated temperature in kelvin still ends in °C
    (hot,) = series_from_frame(pd.DataFrame({"t [s]": [0, 1], "T": [1000, 1100]}),
                               column_map={"T": ("oil_temperature", "K", 0.3, 13.15)})
    assert hot.condition == {} and hot.channel("oil_temperature")[0] == pytest.approx(40.0)


@pytest.mark.parametrize(("entry", "words"), [
    (("P1", "bar", 0.0, 1.0), "non-zero gain"),
    (("P1", "bar", float("nan"), 0.0), "non-zero gain"),
    (("P1", "bar", 1.0), "[channel, unit, gain, offset]"),
    (("skip", "-", 2.0, 0.0), "leaves the column out"),
    (("record", "bar"), "label column"),
])
def test_bad_column_map_entries_name_the_column(entry, words):
    frame = pd.DataFrame({"t [s]": [0.0, 1.0], "PT1": [1.0, 2.0]})
    with pytest.raises(InputError) as err:
        series_from_frame(frame, column_map={"PT1": entry})
    assert err.value.field == "PT1" and words in err.value.message


def test_a_real_loggers_tab_file_imports_through_a_column_map():
    """A rotary actuator's recording (vtnsi data set, ``tests/real_slices.py``) as it is
    written: tab-separated raw 14-bit ADC counts, a sample index for time, the node's
    features as text columns; read through a column map with no change to a count."""
    import csv

    from tests.real_slices import vtnsi_slice

    cmap = {"Time": ("t", "s", 1.0 / 250.0, -1.0 / 250.0),  # the rate is not documented
            "PG_1": ("pg1", "-"), "PG_2": ("pg2", "-"), "Angle": ("angle", "-"),
            "Internal_Temp": ("node_temperature", "degC")}
    cmap |= {c: ("skip", "-") for c in ("Accel_1", "Accel_2", "Accel_3", "Temp_1", "Temp_2",
                                        "Temp_3", "PG_3", "Lim_1", "Lim_2", "Lim_3",
                                        "F_Names", "F_Values", "Prediction")}
    for path in vtnsi_slice():
        (rec,) = read_series(path, column_map=cmap)
        with path.open(newline="") as fh:
            rows = list(csv.DictReader(fh, delimiter="\t"))
        assert rec.name == path.name and len(rec) == len(rows) == 400
        assert rec.sample_rate == pytest.approx(250.0) and rec.t[0] == 0.0
        np.testing.assert_array_equal(rec.channel("pg1"), [float(r["PG_1"]) for r in rows])
        np.testing.assert_array_equal(rec.channel("angle"), [float(r["Angle"]) for r in rows])
        assert set(rec.channels) == {"pg1", "pg2", "angle", "node_temperature"}
        assert rec.channel("pg2").min() >= 0.0 and rec.channel("pg2").max() <= 16383.0



def test_date_times_and_empty_cells_are_refused_with_what_to_do() -> None:
    """An analyst's pass: a logger's wall-clock column was "a column of labels?", an empty
    cell of a mixed-rate logger "NaN or infinite"."""
    stamps = b"stamp;P1 [bar]\n2026-11-20 14:40:00;1\n2026-11-20 14:40:01;2\n"
    with pytest.raises(InputError) as exc:
        read_series(stamps, column_map={"stamp": ("t", "s")})
    assert exc.value.field == "stamp" and "date-times" in exc.value.message
    with pytest.raises(InputError) as exc:
        read_series(b"t [s];P1 [bar];Q [l/min]\n0;1;\n1;2;3\n")
    assert exc.value.field == "Q [l/min]" and "an empty cell" in exc.value.message
    assert "fill them forward" in exc.value.message


def test_a_column_map_that_is_no_mapping_is_refused_naming_it():
    """A list of pairs raised "'list' object has no attribute 'items'" (a library user's
    pass): refused, not read, since a column named twice in it would be chosen silently."""
    frame = pd.DataFrame({"time": [0.0, 1.0, 2.0], "PS1": [150.0, 151.0, 152.0]})
    for cmap, field in (([("time", ("t", "s"))], "column_map"), ({"time": "t"}, "time"),
                        ({"PS1": ("P_pump", "bar", "x", 0.0)}, "PS1")):
        with pytest.raises(InputError) as caught:
            series_from_frame(frame, column_map=cmap)  # type: ignore[arg-type]
        assert caught.value.field == field
    with pytest.raises(InputError, match=r"dict\(pairs\)"):
        read_series(frame, column_map=[("time", ("t", "s"))])  # type: ignore[arg-type]


def test_a_channel_the_rig_does_not_know_is_noted_with_the_nearest_name():
    """A misspelt column map (``P_pmup``, ``Q_meter_b``) kept the channel under its wrong
    name without a word (a library user's pass): read with the rig's channels, each record
    says so and names the channel meant; the right names, a condition and a pump flow
    meter give no note."""
    frame = pd.DataFrame({"time": [0.0, 1.0, 2.0], "pp": [150.0, 151.0, 152.0],
                          "qb": [30.0, 30.0, 30.0], "qp": [31.0, 31.0, 31.0],
                          "T": [40.0, 40.0, 40.0]})
    cmap = {"time": ("t", "s"), "pp": ("P_pmup", "bar"), "qb": ("Q_meter_b", "l/min"),
            "qp": ("Q_pump", "l/min"), "T": ("oil_temperature", "degC")}
    channels = reference_rig().channels()
    (rec,) = series_from_frame(frame, column_map=cmap, expected=channels)
    [note] = rec.notes
    assert note.startswith("channel(s) P_pmup, Q_meter_b are not channels of the rig's model")
    assert "did you mean 'P_pump' for 'P_pmup', 'Q_meter_B' for 'Q_meter_b'?" in note
    assert rec.window(0.0, 1.0).notes == rec.notes
    right = cmap | {"pp": ("P_pump", "bar"), "qb": ("Q_meter_B", "l/min")}
    assert series_from_frame(frame, column_map=right, expected=channels)[0].notes == ()


def test_without_the_rig_a_channel_of_no_rig_model_is_noted_too():
    """Without the rig's channels ``read_series`` kept ``P_pmup`` without a word (a
    review's leftover): every rig model's channels are known, and a name none of them has
    is noted with the nearest; a channel of another circuit's model (the ZeMA rig's
    ``Q_work``) and the right names give none; the values are those read with the rig."""
    frame = pd.DataFrame({"time": [0.0, 1.0, 2.0], "pp": [150.0, 151.0, 152.0],
                          "qb": [30.0, 30.0, 30.0], "qw": [29.0, 29.0, 29.0],
                          "T": [40.0, 40.0, 40.0]})
    cmap = {"time": ("t", "s"), "pp": ("P_pmup", "bar"), "qb": ("Q_meter_b", "l/min"),
            "qw": ("Q_work", "l/min"), "T": ("oil_temperature", "degC")}
    (rec,) = read_series(frame, column_map=cmap)
    [note] = rec.notes
    assert note.startswith("channel(s) P_pmup, Q_meter_b are not channels of any rig model "
                           "hydrodiag builds (F_friction, P1, ")
    assert "Q_work" in note.split(":")[0]          # among the known, not the unknown
    assert "(expected=rig.channels() checks against the rig's own)" in note
    assert note.endswith("did you mean 'P_pump' for 'P_pmup', 'Q_meter_B' for 'Q_meter_b'?")
    (with_rig,) = series_from_frame(frame, column_map=cmap,
                                    expected=reference_rig().channels())
    assert with_rig.notes != rec.notes and rec.channels.keys() == with_rig.channels.keys()
    for name, values in rec.channels.items():
        np.testing.assert_array_equal(values, with_rig.channels[name])
    assert (rec.units, rec.condition) == (with_rig.units, with_rig.condition)
    right = cmap | {"pp": ("P_pump", "bar"), "qb": ("Q_meter_B", "l/min")}
    assert series_from_frame(frame, column_map=right)[0].notes == ()
