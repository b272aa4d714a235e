"""``hydrodiag pump-leak``: the pump's leak per stored cycle from the command line, on ZeMA
cycles imported with ``hydrodiag import zema`` (the temperature-span slice: 18 healthy and 18
severely leaking cycles; the labels only score)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from app.cli import cli
from diagnostics.real.zema import load_1hz
from tests.real_slices import zema_span_slice

ZEMA_RIG = Path(__file__).resolve().parents[2] / "sim" / "rigs" / "zema.yaml"


@pytest.fixture
def imported(runner: CliRunner) -> tuple[CliRunner, np.ndarray]:
    root = zema_span_slice()
    assert runner.invoke(cli, ["rigs", "add", str(ZEMA_RIG)]).exit_code == 0
    done = runner.invoke(cli, ["import", "zema", "--rig", "2", "--root", str(root),
                               "--first", "1", "--last", "36",
                               "--started-at", "2026-11-20T08:00:00Z"])
    assert done.exit_code == 0, done.output
    _, labels = load_1hz(root)
    return runner, np.asarray(labels.leakage).astype(int)


def test_the_leak_of_every_stored_cycle_and_its_steps(
        imported: tuple[CliRunner, np.ndarray]) -> None:
    runner, lab = imported
    shown = runner.invoke(cli, ["pump-leak", "--rig", "2", "--cycles", "--min-segment", "3"])
    assert shown.exit_code == 0, shown.output
    assert f"36 cycles, {int((lab > 0).sum())} leaking" in shown.stdout
    assert "segments between the steps of the leak" in shown.stdout
    assert "median leak [l/min]" in shown.stdout and "pressure [bar]" in shown.stdout
    answer = runner.invoke(cli, ["pump-leak", "--rig", "2", "--json", "--min-segment", "3"])
    assert answer.exit_code == 0, answer.output
    out = json.loads(answer.stdout)
    assert [c["leaking"] for c in out["cycles"]] == list(lab > 0)
    assert f"{len(out['shifts'])} step(s) of the leak" in shown.stdout
    # the table's rows are the segments between the steps
    assert shown.stdout.count("…") == len(out["shifts"]) + 1
    # each cycle's clock time from the import's start, in order
    times = [c["measured_at"] for c in out["cycles"]]
    assert times == sorted(times) and times[0].startswith("2026-11-20T08:00:00")


def test_the_latest_cycles_by_clock_time(imported: tuple[CliRunner, np.ndarray]) -> None:
    runner, lab = imported
    answer = runner.invoke(cli, ["pump-leak", "--rig", "2", "--json", "--last", "24"])
    assert answer.exit_code == 0, answer.output
    out = json.loads(answer.stdout)
    assert [c["series_id"] for c in out["cycles"]] == list(range(13, 37))
    assert [c["leaking"] for c in out["cycles"]] == list(lab[12:] > 0)
    assert out["cycles"][0]["measured_at"].startswith("2026-11-20T08:12:00")  # a cycle a min
    shown = runner.invoke(cli, ["pump-leak", "--rig", "2", "--last", "24"])
    assert "note: read the latest 24 of the rig's 36 stored cycles" in shown.output


def test_bad_options_are_named(imported: tuple[CliRunner, np.ndarray]) -> None:
    """Exit code 1 (the command's main) with the error naming the option the user typed."""
    runner, lab = imported
    healthy = ",".join(str(i + 1) for i in np.flatnonzero(lab == 0))  # ids 1-36 in order
    for args, option, said in (
            (["--rig", "2", "--baseline", "1,2"], "--baseline", "at least 10"),
            (["--rig", "2", "--window", "0"], "--window", "greater than 0"),
            (["--rig", "1"], "--series", "import its cycles first"),
            (["--rig", "1", "--series", "1,2"], "--series", "another rig"),
            (["--rig", "2", "--series", healthy], "--baseline", "no separate leaking group"),
            (["--rig", "2", "--series", "1,2"], "--series", "at least 10 cycles"),
            (["--rig", "2", "--series", "1,2", "--last", "24"], "--last", "not both"),
            (["--rig", "9"], "--rig", "no rig")):
        bad = runner.invoke(cli, ["pump-leak", *args])
        assert bad.exit_code != 0, bad.output
        assert bad.exception.field == option, (args, bad.exception)
        assert said in str(bad.exception.message), (args, bad.exception)
