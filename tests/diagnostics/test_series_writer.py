"""Records written as one import-format file read back as they were
(``diagnostics/series_writer.py``)."""

from __future__ import annotations

import dataclasses
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from diagnostics.series_writer import series_table, write_series
from diagnostics.timeseries import SeriesRecord, read_series
from sim.errors import InputError

START = datetime(2026, 11, 20, 8, tzinfo=UTC)


def _records() -> list[SeriesRecord]:
    rng = np.random.default_rng(4)
    out = []
    for k, load in enumerate((2100.0, 4200.0)):
        t = np.arange(0.0, 1.0, 0.01)
        out.append(SeriesRecord(
            f"run-{k}", t, {"P1": 5e6 + 1e5 * rng.standard_normal(t.size),
                            "x": 0.2 * t},
            {"P1": "Pa", "x": "m"}, np.where(t < 0.5, "working", "return"),
            {"load": load, "oil_temperature": 40.0 + k}))
    return out


@pytest.mark.parametrize("suffix", [".csv", ".csv.gz", ".parquet"])
def test_records_read_back_with_values_phases_conditions_and_clock_times(
        tmp_path: Path, suffix: str) -> None:
    records = [dataclasses.replace(r, started_at=START + timedelta(minutes=3 * k))
               for k, r in enumerate(_records())]
    path = tmp_path / f"runs{suffix}"
    assert write_series(records, path) == 200
    back = read_series(path)
    assert [r.name for r in back] == ["run-0", "run-1"]
    for a, b in zip(records, back, strict=True):
        # shortest round-trip text: the values come back bit for bit
        assert np.array_equal(a.channels["P1"], b.channels["P1"])
        assert b.phase is not None and a.phase is not None
        assert list(b.phase) == list(a.phase)
        assert b.condition == a.condition
        # each record keeps its own clock time: the file's start plus its moved t
        assert b.measured_at == a.measured_at
        assert b.t - b.t[0] == pytest.approx(a.t - a.t[0], abs=1e-9)


def test_records_without_a_clock_keep_their_own_times(tmp_path: Path) -> None:
    table, header = series_table(_records())
    assert header == {} and list(table.columns[:3]) == ["record", "t [s]", "phase"]
    path = tmp_path / "runs.csv"
    write_series(_records(), path)
    back = read_series(path)
    assert all(r.started_at is None and r.t[0] == 0.0 for r in back)


def test_what_the_import_could_not_read_back_is_refused(tmp_path: Path) -> None:
    one, two = _records()
    with pytest.raises(InputError) as err:
        series_table([one, dataclasses.replace(two, started_at=START)])
    assert err.value.field == "started_at"
    with pytest.raises(InputError) as err:
        series_table([one, dataclasses.replace(two, name="run-0")])
    assert err.value.field == "records" and "'run-0' twice" in err.value.message
    with pytest.raises(InputError) as err:
        series_table([])
    assert err.value.field == "records"
    with pytest.raises(InputError) as err:
        write_series([one], tmp_path / "missing" / "runs.csv")
    assert err.value.field == "file"
    with pytest.raises(InputError) as err:  # written as CSV, it would be read as nothing
        write_series([one], tmp_path / "runs.txt")
    assert err.value.field == "file" and ".parquet" in err.value.message
    assert not (tmp_path / "runs.txt").exists()
