"""What every command shares: output paths checked before the work, documents read as
their authors wrote them, ids bounded (app/cli_support.py)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.cli_support import store_session
from app.db.models import RigVersion
from tests.app.conftest import store_count

README_RECORD = """rig_id: 1
measured_at: "2026-11-22T08:30:00Z"
condition: {oil_temperature: 40.0, load_force: 2100.0}
pump_pressure: 14.50e5
p1: 11.88e5
p2: 1.202e5
flow_B: 4.643e-4
flow_C: 4.172e-4
speed_work: 0.1881
speed_return: 0.2177
"""


@pytest.mark.parametrize("command", [
    ["simulate", "--steady", "--output", "{missing}/run.csv"],
    ["simulate", "--steady", "--output", "{folder}"],
    ["sweep", "{doc}", "--output", "{missing}/sweep.csv"],
    ["report", "diagnosis", "1", "--output", "{missing}/report.html"],
    ["report", "trends", "--output", "{folder}"],
    ["diagnose-batch", "{doc}", "--output", "{missing}/results.jsonl"],
    ["discover", "--series", "1", "--rig", "1", "--report", "{missing}/report.html"],
])
def test_an_output_that_cannot_be_written_is_refused_before_the_work(
        runner: CliRunner, tmp_path: Path, command: list[str]) -> None:
    """A missing folder or a folder as the file: refused naming the option, before anything
    runs or is stored (discover stored its new rig version, then failed writing the
    report: each retry stored one more)."""
    folder = tmp_path / "a-folder.csv"
    folder.mkdir()
    doc = tmp_path / "doc.json"
    doc.write_text("{}")
    args = [a.format(missing=tmp_path / "missing", folder=folder, doc=doc) for a in command]
    with store_session():   # the store, preloaded (a listing makes none)
        pass
    before = store_count(RigVersion)
    result = runner.invoke(cli, args)
    assert result.exit_code != 0
    option = next(a for a in command if a in ("--output", "--out", "--report"))
    assert f"{option}:" in str(result.exception), result.output
    assert store_count(RigVersion) == before


def test_yaml_numbers_as_engineers_write_them_are_numbers(runner: CliRunner,
                                                          tmp_path: Path) -> None:
    """``14.50e5`` and ``4.643e-4`` (YAML 1.2 and JSON floats; PyYAML's YAML 1.1 read the
    first as text and the record was refused as 'not a valid dictionary')."""
    path = tmp_path / "record.yaml"
    path.write_text(README_RECORD)
    result = runner.invoke(cli, ["diagnose", str(path), "--no-store", "--json"])
    assert result.exit_code == 0, result.output
    assert '"top": "valve"' in result.stdout


def test_a_file_that_is_not_utf8_and_ids_beyond_the_store_are_refused(
        runner: CliRunner, tmp_path: Path) -> None:
    path = tmp_path / "record.json"
    path.write_bytes(b"\xff\xfe\x00bad")
    result = runner.invoke(cli, ["diagnose", str(path), "--no-store"])
    assert result.exit_code != 0 and "not UTF-8" in str(result.exception)
    for args in (["diagnose", "--series", "99999999999999999999", "--no-store"],
                 ["rigs", "show", "99999999999999999999"],
                 ["report", "diagnosis", "99999999999999999999"],
                 ["keys", "revoke", "99999999999999999999"]):
        result = runner.invoke(cli, args)
        assert result.exit_code != 0, args
        assert not isinstance(result.exception, OverflowError), args


def _commands() -> Iterator[tuple[list[str], Any]]:
    """Every command of ``hydrodiag`` with its path (``["calibrate", "pump"]``)."""
    from typer.main import get_command

    def walk(cmd: Any, path: list[str]) -> Iterator[tuple[list[str], Any]]:
        if hasattr(cmd, "commands"):  # a group (typer's own click, not click's classes)
            for name, sub in cmd.commands.items():
                yield from walk(sub, [*path, name])
        else:
            yield path, cmd

    return walk(get_command(cli), [])


def test_every_unit_written_in_a_help_text_is_shown(runner: CliRunner) -> None:
    """Rich reads ``[degC]`` as markup and drops it (issue 12: units lost from the help);
    every bracketed unit a command's help text holds must be in what ``--help`` prints."""
    import re

    checked = 0
    for path, cmd in _commands():
        texts = [cmd.help or ""] + [getattr(p, "help", None) or "" for p in cmd.params]
        units = {u for t in texts for u in re.findall(r"\[([^\[\]\s]{1,16})\]", t)}
        if not units:
            continue
        shown = runner.invoke(cli, [*path, "--help"], terminal_width=240).stdout
        flat = re.sub(r"[\s│]+", "", shown)
        for unit in units:
            assert f"[{unit}]" in flat, (path, unit)
            checked += 1
    assert checked > 20


def test_an_estimate_is_shown_with_the_digits_its_interval_needs() -> None:
    from app.cli_support import estimate_text

    # was "6e-05 … 6e-05" beside 5.999e-05
    assert estimate_text(5.99925e-05, 5.9989e-05, 5.9996e-05) == (
        "5.999e-05", "5.999e-05 … 6e-05")
    assert estimate_text(8.3025e-05, 8.30244e-05, 8.30269e-05) == (
        "8.302e-05", "8.302e-05 … 8.303e-05")
    assert estimate_text(0.5, 0.25, 0.75) == ("0.5", "0.25 … 0.75")


def test_a_clearance_is_shown_in_micrometres_and_other_quantities_as_they_are() -> None:
    from app.cli_support import shown_estimate

    assert shown_estimate(6.007e-05, 5.844e-05, 6.174e-05, "m") == (
        "60.07", "58.44 … 61.74", "µm")
    assert shown_estimate(5.99925e-05, 5.9989e-05, 5.9996e-05, "m") == (
        "59.99", "59.99 … 60", "µm")
    # a stroke or a length of a centimetre or more stays in m; other units as they are
    assert shown_estimate(0.2, 0.19, 0.21, "m") == ("0.2", "0.19 … 0.21", "m")
    assert shown_estimate(2.1e6, 2.0e6, 2.2e6, "Pa") == ("2.1e+06", "2e+06 … 2.2e+06", "Pa")
    assert shown_estimate(1.33, 1.33, 7.2, "1") == ("1.33", "1.33 … 7.2", "1")


def test_import_names_are_checked_and_a_non_utf8_file_name_is_kept_readable(
        runner: CliRunner, tmp_path: Path) -> None:
    """``--name $'x\\xff'`` failed at the commit with a UnicodeEncodeError traceback; a
    file whose name is not UTF-8 (a logger's Latin-1 name) did the same."""
    content = "t [s],P1 [bar]\n0,1\n1,2\n"
    plain = tmp_path / "run.csv"
    plain.write_text(content)
    for name in ("x\udcff", "", "two words"):
        result = runner.invoke(cli, ["import", "series", str(plain), "--rig", "1",
                                     "--name", name])
        assert result.exit_code != 0 and "name:" in str(result.exception), name
    latin = tmp_path / "w\udcffn.csv"
    latin.write_text(content)
    result = runner.invoke(cli, ["import", "series", str(latin), "--rig", "1", "--name", "l1"])
    assert result.exit_code == 0, result.output


def test_errors_name_the_option_typed(runner: CliRunner, tmp_path: Path) -> None:
    """Not the API's field a command fills from it (displacement_m3_rad, sample_rate)."""
    sample = Path(__file__).resolve().parents[2] / "docs" / "samples" / "bench_sample.csv"
    for args, option in (
            (["calibrate", "pump", str(sample), "--name", "x", "--pump", "p",
              "--displacement", "-1"], "--displacement"),
            (["simulate", "--solver", "ros2", "--sample-rate", "100"], "--sample-rate"),
            (["simulate", "--steady", "--output", str(tmp_path / "run.csv")], "--output"),
            (["simulate", "--rtol", "nan"], "--rtol")):
        result = runner.invoke(cli, args)
        assert result.exit_code != 0, args
        assert getattr(result.exception, "field", None) == option, (args, result.exception)


def test_a_narrow_terminal_folds_table_cells_instead_of_cutting_them() -> None:
    """At 40 columns ``cylinder+valve`` and ``cylinder+pump`` both read ``cylinder+…`` and
    intervals lost their digits (a CLI pass): the cells fold onto more lines, every
    character kept."""
    import io

    from rich.table import Table

    from app.cli_support import WideWhenPiped

    table = Table("hypothesis", "probability", "parameters (95 % interval)")
    for name in ("cylinder+valve", "cylinder+pump"):
        table.add_row(name, "0.4812", "cc = 91.28 µm (87.41 to 95.20), cv = 41.07 µm (39.8 to 42.3)")
    out = io.StringIO()
    narrow = WideWhenPiped(file=out, width=40, force_terminal=True, color_system=None)
    narrow.print(table)
    text = out.getvalue()
    assert "…" not in text
    cells = [line.split("│")[1:-1] for line in text.splitlines() if line.startswith("│")]
    column = ["".join(c[k].strip() for c in cells) for k in range(3)]
    assert column[0] == "cylinder+valvecylinder+pump"
    assert column[1] == "0.48120.4812"
    assert column[2].count("95.20") == 2 and column[2].count("42.3)") == 2


def test_every_option_name_is_shown_whole_in_an_80_column_help(runner: CliRunner) -> None:
    """An 80-column ``calibrate pump --help`` cut ``--displacement-cm3-rev`` to
    ``--displacement-cm3-r…`` (a CLI pass): the ids' range ``[1<=x<=2147483647]`` widened
    the types column.  Every option of every command is in its help whole, and no help
    shows reST's double backquotes."""
    checked = 0
    for path, cmd in _commands():
        shown = runner.invoke(cli, [*path, "--help"], terminal_width=80).stdout
        for param in cmd.params:
            for name in param.opts:
                if name.startswith("--"):
                    assert name in shown, (path, name)
                    checked += 1
        assert "2147483647" not in shown, path
        assert "``" not in shown, path   # reST literals ('VACUUM INTO', not ``VACUUM INTO``)
    assert checked > 100


@pytest.mark.parametrize(("args", "says"), [
    (["history", "show", "0"], "0 is not an id: ids run from 1 to 2147483647"),
    (["rigs", "rediagnose", "1", "--version", "x"], "'x' is not an id (a whole number from 1)"),
    (["simulate", "--steady", "--rig", "-3"], "-3 is not an id"),
    # a negative id was "No such option: -1" (click reads it as an option; a review's
    # leftover): ids are the store's, from 1, and the message says where they are listed
    (["history", "show", "-1"], "Invalid value for 'diagnosis_id': -1 is not an id: ids run "
     "from 1 to 2147483647, and a negative one counts nothing from the end (`hydrodiag "
     "history list --limit 1` names the newest)"),
    (["history", "show", "-1", "--json"], "'diagnosis_id': -1 is not an id"),
    (["report", "diagnosis", "-4", "--output", "r.html"], "'diagnosis_id': -4 is not an id"),
    (["rigs", "show", "-2"], "'rig_id': -2 is not an id: ids run from 1 to 2147483647, and "
     "a negative one counts nothing from the end (`hydrodiag rigs list` names them)"),
    (["keys", "revoke", "-1"], "(`hydrodiag keys list` names them)"),
    # an option's negative value stays the option's, an unknown option click's
    (["rigs", "rediagnose", "1", "--version", "-1"], "'--version': -1 is not an id: ids run"),
    (["history", "show", "--jsn", "3"], "No such option: --jsn"),
])
def test_an_id_that_no_store_can_hold_is_refused_before_the_store_is_opened(
        runner: CliRunner, tmp_path: Path, args: list[str], says: str) -> None:
    result = runner.invoke(cli, args, terminal_width=200)
    assert result.exit_code == 2, result.output
    assert says in " ".join(result.output.replace("│", " ").split())
    assert not any(tmp_path.iterdir())   # no store made


@pytest.mark.parametrize("args", [
    ["diagnose", "missing.yaml"], ["diagnose", "missing.csv", "--rig", "1"],
    ["diagnose", "{bad}"]])
def test_a_record_file_is_read_before_a_store_is_made(runner: CliRunner, tmp_path: Path,
                                                      args: list[str]) -> None:
    """``diagnose missing.yaml`` made a new store in the current folder, then said the file
    was missing (a CLI pass): the file is read and checked first."""
    bad = tmp_path / "bad.yaml"
    bad.write_text("rig_id: 1\nmeasured_at: yesterday\n", encoding="utf-8")
    data = tmp_path / "store"
    runner.env = {"HYDRODIAG_DATA_DIR": str(data)}
    result = runner.invoke(cli, [a.replace("{bad}", str(bad)) for a in args])
    assert result.exit_code != 0
    assert getattr(result.exception, "field", "").split(".")[0] in ("FILE", "record"), \
        result.output
    assert not data.exists()
