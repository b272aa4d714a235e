"""What a cycle result says beside its numbers (sim.cycle_result.CycleResult.notes)."""

from __future__ import annotations

from sim.cycle_result import VACUUM_GAUGE
from sim.rigs import Condition, reference_rig
from sim.steady import steady_cycle


def test_an_overrunning_load_s_pressure_below_vacuum_is_said_to_a_library_user() -> None:
    """−2.1 kN (an overrunning load, valid) put chamber 1 at −7.86 bar gauge on the steady
    path with no word outside the HTTP answer (a library user's pass)."""
    result = steady_cycle(reference_rig(), None, Condition(load=-2100.0))
    assert result.working["P1"] < VACUUM_GAUGE
    (note,) = [n for n in result.notes() if n.startswith("below vacuum")]
    assert f"working.P1 reaches {result.working['P1'] / 1e5:.4g} bar gauge" in note
    assert steady_cycle(reference_rig(), None, Condition(load=2100.0)).notes() == []


def test_a_stalled_stroke_is_said() -> None:
    """A load the pump cannot push (the relief opens): the stroke does not complete, and the
    steady path's note names no time (its duration is infinite for a stall)."""
    result = steady_cycle(reference_rig(), None, Condition(load=60e3))
    assert not result.working.completed
    (note,) = [n for n in result.notes() if n.startswith("the working stroke")]
    assert "did not reach its end (creep speed" in note and " in inf s" not in note
