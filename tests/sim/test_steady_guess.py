"""The first guesses kept between steady solves belong to their own rig."""

from __future__ import annotations

import numpy as np
import pytest

from sim import steady as steady_module
from sim.errors import ParameterError
from sim.rigs import Condition, load_rig, reference_rig, reference_rig_document
from sim.steady import steady_cycle, steady_phase


def test_a_guess_is_used_only_by_the_rig_that_made_it() -> None:
    """A guess is kept under the rig's ``id``; a new rig that reuses a collected rig's
    ``id`` must not start from it.  Planted: an entry under this rig's key that belongs
    to another rig and could not even be used (wrong length) — the solve ignores it and
    gives the fresh answer, and the entry is replaced by this rig's own point."""
    rig = load_rig(reference_rig_document())
    cond = Condition(load=2100.0, oil_temperature=40.0)
    fresh = steady_phase(rig, "working", None, cond).state.copy()
    key = (id(rig), "working")
    assert steady_module._GUESS[key][0] is rig
    steady_module._GUESS[key] = (reference_rig(), np.zeros(1))
    again = steady_phase(rig, "working", None, cond).state
    np.testing.assert_allclose(again, fresh, rtol=1e-9, atol=1e-12)
    assert steady_module._GUESS[key][0] is rig
    assert steady_module._GUESS[key][1].shape == fresh.shape


def test_a_rig_started_from_its_own_guess_finds_the_same_point() -> None:
    """With its own guess kept, the rig's steady point is the one found from the transient
    start (the guess only starts Newton)."""
    rig = load_rig(reference_rig_document())
    cond = Condition(load=4200.0, oil_temperature=50.0)
    first = steady_phase(rig, "return", None, cond).state.copy()
    second = steady_phase(rig, "return", None, cond).state
    assert second == pytest.approx(first, rel=1e-9, abs=1e-12)


def test_a_steady_point_does_not_depend_on_what_the_process_solved_first() -> None:
    """Every steady solve of a rig started from the first point solved for it, at whatever
    condition and overrides that was: the same question on two copies of one rig, one
    asked something else first, differed in the last digits (and through the fast path's
    Newton starts moved a diagnosis by 1e-7 relative: a process pool against the process
    that made the records).  The start is now the rig's own nominal point."""
    asked = ({"valve.cv": 50e-6}, Condition(load=3100.0, oil_temperature=45.0))
    first = load_rig(reference_rig_document())
    alone = steady_cycle(first, *asked)
    other = load_rig(reference_rig_document())
    steady_cycle(other, {"cylinder.cc": 130e-6}, Condition(load=6000.0, oil_temperature=25.0))
    again = steady_cycle(other, *asked)
    assert again.working == alone.working and again.return_ == alone.return_


@pytest.mark.parametrize(("condition", "overrides", "field"), [
    ({"load": float("nan")}, None, "condition.force"),
    ({"back_pressure": float("nan")}, None, "condition.back_pressure"),
    ({"oil_temperature": float("inf")}, None, "condition.oil_temperature"),
    ({}, {"pump.Rlp": float("nan")}, "overrides.pump.Rlp"),
    ({}, {"cylinder.Fu": float("nan")}, "overrides.cylinder.Fu"),
])
def test_a_nan_is_refused_not_answered_with_the_last_point(
        condition: dict[str, float], overrides: dict[str, float] | None, field: str) -> None:
    """A NaN load returned, unchanged, the 6.3 kN point solved before it: every bound
    compared false, and the solver took the NaN residual at its guess as converged (a
    library user's pass).  Now the value is refused, naming it."""
    rig = reference_rig()
    steady_cycle(rig, None, Condition(load=6300.0))       # the point a NaN came back as
    with pytest.raises(ParameterError, match="must be a finite number") as caught:
        steady_cycle(rig, overrides, Condition(**condition))
    assert caught.value.field == field
