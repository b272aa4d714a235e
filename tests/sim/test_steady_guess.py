"""The first guesses kept between steady solves belong to their own rig."""

from __future__ import annotations

import numpy as np
import pytest

from sim import steady as steady_module
from sim.rigs import Condition, load_rig, reference_rig, reference_rig_document
from sim.steady import steady_phase


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
