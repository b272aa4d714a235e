"""``hydrodiag import zema --native`` and ``--table``: the data set's raw cycles at their
native rates into the store, and the adapter's cycles as one series file that the HTTP
import reads as it is (``app/cli_import.py``)."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import select
from typer.testing import CliRunner

from app.cli import cli
from app.cli_support import store_session
from app.db.models import MeasuredSeries
from app.services.series import as_record
from diagnostics.real.zema import FULLRES_CYCLES, load_1hz
from tests.app.conftest import store_count
from tests.real_slices import NATIVE_SLICE_S, zema_native_slice

ZEMA_RIG = Path(__file__).resolve().parents[2] / "sim" / "rigs" / "zema.yaml"
#: the slice's cycles numbered 400-800: rows 8, 4 and 7 of the raw file
IN_RANGE = (409, 439, 753)
START = datetime(2026, 11, 20, 8, tzinfo=UTC)


def _stored(name: str) -> dict[str, MeasuredSeries]:
    with store_session() as session:
        rows = session.scalars(select(MeasuredSeries).where(MeasuredSeries.name == name)).all()
        session.expunge_all()
    return {r.record: r for r in rows}


def test_native_rate_cycles_are_stored_at_their_rate_and_average_to_the_1hz_files(
        runner: CliRunner, tmp_path: Path) -> None:
    root = zema_native_slice()
    assert runner.invoke(cli, ["rigs", "add", str(ZEMA_RIG)]).exit_code == 0
    table = tmp_path / "native.csv.gz"
    result = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                                 "--native", "--first", "400", "--last", "800",
                                 "--name", "native", "--table", str(table),
                                 "--started-at", "2026-11-20T08:00:00Z"])
    assert result.exit_code == 0, result.output
    assert "3 ZeMA cycles stored" in result.stdout
    assert f"({3 * NATIVE_SLICE_S * 100} samples at 100 Hz) written" in result.stdout
    rows = _stored("native")
    assert sorted(rows) == [f"cycle-{c}" for c in sorted(IN_RANGE)]
    # the 1 Hz files of the data set are the 1-second block means of the raw samples
    # (SOURCE.md): the stored 100 Hz cycles give them back, unit for unit
    data, _ = load_1hz(root, [FULLRES_CYCLES.index(c) + 1 for c in IN_RANGE])
    for k, cycle in enumerate(IN_RANGE):
        row = rows[f"cycle-{cycle}"]
        assert row.sample_rate == pytest.approx(100.0)
        assert row.n_samples == NATIVE_SLICE_S * 100
        # cycle k measured (k − 1) minutes after cycle 1's start, as for the 1 Hz cycles
        assert row.measured_at == START + timedelta(minutes=cycle - 1)
        record = as_record(row)
        for sensor, channel, unit in (("PS1", "p_pump", 1e5), ("PS2", "p_work", 1e5),
                                      ("FS1", "q_work", 1.0 / 60000.0),
                                      ("EPS1", "motor_power", 1.0),
                                      ("TS1", "oil_temperature", 1.0)):
            blocks = record.channel(channel).reshape(NATIVE_SLICE_S, 100).mean(axis=1)
            expected = data.sensors[sensor][k, :NATIVE_SLICE_S] * unit
            np.testing.assert_allclose(blocks, expected, rtol=1e-12, err_msg=channel)
    # the written table is what the HTTP import reads: the same samples from the same
    # starts, so it is refused as stored already — and nothing more is stored
    again = runner.invoke(cli, ["import", "series", str(table), "--rig", "2", "--name",
                                "again"])
    # (every cycle of it: the table counts them from the file's start, the store from 0)
    assert again.exit_code != 0 and "3 of these records are stored" in str(again.exception)
    assert "hydrodiag rigs series 2 --delete" in " ".join(str(again.exception).split())
    assert store_count(MeasuredSeries) == 3
    # a cycle not stored yet, written as Parquet and imported through the series path,
    # keeps its rate, values and clock time
    parquet = tmp_path / "one.parquet"
    written = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                                  "--native", "--first", "1000", "--last", "1100",
                                  "--no-store", "--table", str(parquet),
                                  "--started-at", "2026-11-20T08:00:00Z"])
    assert written.exit_code == 0, written.output
    assert store_count(MeasuredSeries) == 3
    imported = runner.invoke(cli, ["import", "series", str(parquet), "--rig", "2", "--name",
                                   "from-table"])
    assert imported.exit_code == 0, imported.output
    (row,) = _stored("from-table").values()
    assert row.record == "cycle-1092" and row.sample_rate == pytest.approx(100.0)
    assert row.measured_at == START + timedelta(minutes=1091)
    data, _ = load_1hz(root, [FULLRES_CYCLES.index(1092) + 1])
    blocks = as_record(row).channel("p_pump").reshape(NATIVE_SLICE_S, 100).mean(axis=1)
    np.testing.assert_allclose(blocks, data.sensors["PS1"][0, :NATIVE_SLICE_S] * 1e5,
                               rtol=1e-12)
    # its remedy can be taken on the command line (it named DELETE /series/{id} alone: a
    # CLI pass): the rig's series listed, one deleted, one of another rig refused
    listed = runner.invoke(cli, ["rigs", "series", "2"], terminal_width=200)
    assert listed.exit_code == 0 and "4 measured series of rig 2" in listed.stdout
    first = min(_stored("native").values(), key=lambda r: r.id).id
    other = runner.invoke(cli, ["rigs", "series", "1", "--delete", str(first)])
    assert getattr(other.exception, "field", None) == "--delete"
    assert store_count(MeasuredSeries) == 4
    gone = runner.invoke(cli, ["rigs", "series", "2", "--delete", str(first)])
    assert gone.exit_code == 0 and store_count(MeasuredSeries) == 3, gone.output


def test_native_import_refuses_a_range_without_raw_cycles(runner: CliRunner,
                                                          tmp_path: Path) -> None:
    root = zema_native_slice()
    assert runner.invoke(cli, ["rigs", "add", str(ZEMA_RIG)]).exit_code == 0
    none = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                               "--native", "--first", "1", "--last", "5"])
    assert none.exit_code != 0 and getattr(none.exception, "field", None) == "--first"
    assert "409, 439" in str(none.exception)
    unwritable = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                                     "--native", "--no-store", "--table",
                                     str(tmp_path / "no" / "such" / "dir.csv")])
    assert unwritable.exit_code != 0
    assert getattr(unwritable.exception, "field", None) == "--table"
    # a bench table is CSV text: pb.xlsx was "written" as CSV (a CLI pass)
    xlsx = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                               "--native", "--no-store", "--bench", str(tmp_path / "pb.xlsx")])
    assert getattr(xlsx.exception, "field", None) == "--bench", xlsx.output
    assert not (tmp_path / "pb.xlsx").exists()
    assert store_count(MeasuredSeries) == 0


@pytest.mark.parametrize("command", ["zema", "series"])
def test_the_import_help_is_whole_at_80_columns(command: str) -> None:
    """An example or a default path too long for typer's help column was cut with '…'
    (a user pass: the data set's default folder and the ISO example of --started-at)."""
    shown = CliRunner().invoke(cli, ["import", command, "--help"], env={"COLUMNS": "80"},
                               terminal_width=80)
    assert shown.exit_code == 0, shown.output
    assert max(len(line) for line in shown.output.splitlines()) <= 80
    text = "".join(shown.output.split())
    assert "2026-11-20T08:00Z" in text
    if command == "zema":
        assert "uci-hydraulic-zema" in text


def test_a_stroke_imported_at_a_wrong_rate_is_noted_by_the_cli(
        runner: CliRunner, tmp_path: Path) -> None:
    """``hydrodiag import series --sample-rate`` prints the note the HTTP import answers:
    a 100 Hz stroke stated as 1 Hz crosses its travel ~140× slower than the pump drives."""
    t = np.arange(0.0, 6.0, 0.01)
    x = np.clip((t - 0.5) * 0.16, 0.0, 0.5)
    data = tmp_path / "stroke.csv"
    data.write_text("x [m],load [N],oil_temperature [degC]\n"
                    + "".join(f"{float(v)!r},4200,40\n" for v in x))
    assert runner.invoke(cli, ["db", "upgrade"]).exit_code == 0
    said = runner.invoke(cli, ["import", "series", str(data), "--rig", "1", "--name", "s",
                               "--sample-rate", "1"])
    assert said.exit_code == 0, said.output
    text = "".join(said.output.split())
    assert "crossesitstravel138×slower" in text and "toolong" in text
    quiet = runner.invoke(cli, ["import", "series", str(data), "--rig", "1", "--name", "q",
                                "--sample-rate", "100"])
    assert quiet.exit_code == 0 and "crosses" not in quiet.output
