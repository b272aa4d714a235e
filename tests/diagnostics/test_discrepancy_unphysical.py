"""A base coefficient re-fitted to an unphysical sign is said (issue 8; a discrepancy pass).

A pressure-dependent seal friction hidden in four records all at 4.2 kN / 40 °C: at one
load the equation-error base re-fit of the piston-force balance reads the extra friction as
Fu = 651 N and Kf = −2148 N·s/m, chooses nothing, and the answer sent the user "outside the
library" without saying that the base had gone unphysical.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from benchmarks.discrepancy_study import _doc_with
from diagnostics.discrepancy.balances import BASE_SIGNS, balance_data
from diagnostics.discrepancy.first_step import split
from diagnostics.discrepancy.selection import Selection, select
from diagnostics.discrepancy.signals import prepare
from diagnostics.discrepancy.synthetic import synthesize
from diagnostics.discrepancy.verdict import unphysical_note
from sim.rigs import load_rig, reference_rig
from sim.rigs.assembly import Condition


def _piston_selection(doc: dict[str, Any], loads: list[float], seed: int) -> Selection:
    rig = load_rig(doc)
    rng = np.random.default_rng(seed)
    recs = [synthesize(rig, Condition(load=f, oil_temperature=40.0), rng=rng, name=f"r{i}")
            for i, f in enumerate(loads)]
    base = reference_rig()
    train, _, _ = split(recs, base)
    data = balance_data(prepare([recs[i] for i in train], base), base.values())
    return select(next(d for d in data if d.balance.name == "piston_force"), bootstrap=0)


def test_a_negative_viscous_friction_at_one_load_is_said() -> None:
    s = _piston_selection(_doc_with("seal_friction_pressure", 3e-5), [4200.0] * 4, 402)
    assert s.chosen is None
    # friction must stay >= 0; the one-load re-fit drives Kf far below 0 (the stored
    # rig's Kf is positive: the seal friction's k_p·Δp, constant at one load, went to Fu
    # and the little that varies with the speed to a negative Kf)
    assert BASE_SIGNS["cylinder.Kf"] > 0
    assert s.unphysical["cylinder.Kf"] < -500.0
    assert s.base_coefficients["cylinder.Kf"] == s.unphysical["cylinder.Kf"]
    note = unphysical_note([s])
    assert note is not None
    assert "cylinder.Kf to -2" in note and "N·s/m" in note and "piston_force" in note
    assert "several loads" in note


def test_a_healthy_design_at_several_loads_has_no_unphysical_base() -> None:
    s = _piston_selection(_doc_with(None), [2100.0, 4200.0, 6300.0], 7)
    assert s.unphysical == {}
    assert unphysical_note([s]) is None
    assert s.base_coefficients["cylinder.Fu"] > 0 and s.base_coefficients["cylinder.Kf"] > 0
