"""The workflow on data hiding a wrong viscosity–temperature law or entrained air."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.discrepancy import discover
from diagnostics.discrepancy.balances import balance_data
from diagnostics.discrepancy.selection import select
from diagnostics.discrepancy.signals import prepare
from diagnostics.discrepancy.synthetic import NOISE, synthesize
from diagnostics.discrepancy.workflow import excess_ratio
from sim.rigs import load_rig, reference_rig, reference_rig_document
from sim.rigs.assembly import Condition
from sim.rigs.schema import validate_rig_document

CONDITIONS = ((2100.0, 40.0), (4200.0, 50.0), (6300.0, 60.0))


def _records(doc: dict, seed: int):
    rig = load_rig(doc)
    rng = np.random.default_rng(seed)
    return [synthesize(rig, Condition(load=L, oil_temperature=T), rng=rng, name=f"L{L:.0f}")
            for L, T in CONDITIONS]


def _with(effect: str, pname: str, value: float, unit: str) -> dict:
    doc = reference_rig_document()
    doc["effects"] = {effect: {"parameters": {pname: {"value": value, "unit": unit}}}}
    return doc


def test_hidden_viscosity_law_is_named_fitted_and_the_held_out_gap_shrinks():
    truth = 0.008  # 1/K: μ at 60 °C 15 % below the stated law
    d = discover(reference_rig_document(), _records(_with("viscosity_law", "lam", truth, "1/K"),
                                                    21), bootstrap=10)
    assert d.verdict == "named"
    assert [n.name for n in d.named] == ["viscosity_law"]
    n = d.named[0]
    assert n.balance == "chamber_flow"
    assert n.value == pytest.approx(truth, rel=0.1)
    # held out at 60 °C: the stated law is most wrong there
    assert d.held_out == ["L6300"]
    assert excess_ratio(d.gap_before, d.gap_after, NOISE) >= 2.0
    spec = validate_rig_document(d.rig_document)
    assert spec.effects["viscosity_law"]["lam"].value == pytest.approx(n.value)


def test_entrained_air_enters_the_chamber_balance_with_its_own_coefficient():
    """Equation error: the chamber-2 balance's air column recovers α0 (sign and size).

    α0 = 1.08e-3 is the study's 16σ size.  Much more air (2e-3) is not recovered: P2
    then swings through near-vacuum inside the 41 ms Savitzky-Golay window, where the
    air compliance is steep, and the smoothed product no longer matches the column.
    """
    truth = 1.08e-3
    rig = reference_rig()
    recs = _records(_with("entrained_air", "alpha", truth, "1"), 22)
    data = {b.balance.name: b for b in balance_data(prepare(recs, rig), rig.values())}
    chamber = data["chamber_flow"]
    assert "entrained_air" in chamber.candidates
    sel = select(chamber, bootstrap=0)
    single = sel.singles["entrained_air"]
    assert single.t > 5.0
    assert single.coefficient == pytest.approx(truth, rel=0.2)
    assert sel.chosen is not None
    assert [t.effect for t in sel.chosen.terms] == ["entrained_air"]


def test_signals_of_a_rig_carrying_the_viscosity_law_use_its_corrected_viscosity():
    """A rig version with the fitted law analyses its data with μ_true, not the stated μ."""
    lam = 0.008
    doc = _with("viscosity_law", "lam", lam, "1/K")
    recs = _records(doc, 21)
    s_aug = prepare(recs, load_rig(doc))
    s_base = prepare(recs, reference_rig())
    for i, (_, T) in enumerate(CONDITIONS):
        mu_aug = s_aug.values["mu"][s_aug.record == i]
        mu_base = s_base.values["mu"][s_base.record == i]
        np.testing.assert_allclose(mu_aug, mu_base * np.exp(-lam * (T - 40.0)), rtol=1e-13)


def test_entrained_air_at_8_sigma_is_confirmed_in_the_build_up_after_the_switches():
    """Air acts in the pressure build-up after each valve switch (``window="build-up"``):
    the output-error re-fit locates its valley there and the held-out check compares
    0-90 % of each phase; over 10-90 % alone the study's 8σ size (α0 = 5.4e-4) was never
    confirmed, and a re-fit started from the equation-error estimate stayed 3.6× off."""
    from benchmarks.discrepancy_study import _case, _doc_with

    truth = 5.4e-4
    d = _case(_doc_with("entrained_air", truth), 7)
    assert [n.name for n in d.named] == ["entrained_air"]
    n = d.named[0]
    # the equation-error estimate is 3-4× off at this size (the build-up lies at the end
    # stops, outside the balance); the re-simulated value is near the truth's.  Not closer
    # than 20 %: the re-fit's costs are multimodal at this scale (10-90 % cost 17.3e3 at
    # 0.535e-3, 44.6e3 at 0.45e-3, local minima near 0.35e-3 and 0.45e-3), and which
    # valley the grid search lands in turns on the start: 0.535e-3 from an equation-error
    # start of 2.2279e-3, 0.441e-3 from 2.2284e-3 (the chamber balance with the held
    # samples of the dwells, issue 8)
    assert n.equation_error > 2.0 * truth
    assert n.value == pytest.approx(truth, rel=0.2)
    # held out: a full stroke and a dwell at the stop, whose dwell carries no air signature
    # (1.5× with the value at 0.535e-3, 1.39× at 0.441e-3)
    assert excess_ratio(d.gap_before, d.gap_after, NOISE, ("steady", "after step")) >= 1.3


def test_a_near_twin_of_the_equation_error_choice_is_told_apart_by_re_simulation():
    """Piston clearance growing with pressure and a wrong viscosity law leave columns
    correlated at 0.99 in the chamber balance (base columns projected out), so the
    equation error alone may prefer either.  Re-simulated from their equation-error
    estimates (:func:`~diagnostics.discrepancy.refit.tell_apart`), the viscosity law also
    changes the valve, pump and friction — which the data do not show — and the
    pressure-dependent clearance wins, at its true size (the study's 16σ size, seed 1007)."""
    from benchmarks.discrepancy_study import _conditions, _doc_with
    from diagnostics.discrepancy.first_step import OUTPUTS
    from diagnostics.discrepancy.refit import tell_apart

    truth = 2.436e-20
    rig = load_rig(_doc_with("piston_clearance_pressure", truth))
    rng = np.random.default_rng(1007)
    records = [synthesize(rig, c, rng=rng, name=name, t_max=sw) for name, c, sw in _conditions()]
    base = reference_rig()
    data = {b.balance.name: b for b in balance_data(prepare(records, base), base.values())}
    singles = select(data["chamber_flow"], bootstrap=0).singles
    options = [{"viscosity_law.lam": float(singles["viscosity_law"].coefficient)},
               {"piston_clearance_pressure.k_c": float(singles["piston_clearance_pressure"]
                                                        .coefficient)}]
    channels = [c for c in OUTPUTS if c in records[0].channels]
    best, group, fits = tell_apart(reference_rig_document(), options, records, channels,
                                   NOISE, 8)
    assert best == 1
    assert 0 not in group                       # told apart, not reported together
    assert fits[1][0]["piston_clearance_pressure.k_c"] == pytest.approx(truth, rel=0.1)
