"""The flow balances on a piston held at its stop (dwell records, issue 8).

With the piston held at the stroke end (ẋ = 0, the pressures steady) the chamber-2
0-junction says meter C = the piston leak at the full working pressure, and the valve's
0-junctions say B − C = the spool leak (paper 002 eqs. 23-24, 34-36): hand-checkable
equations that the stop force does not enter.  These tests check that the balances keep
those samples, that the junctions hold there to the solver's accuracy on noise-free
simulations with each leak effect, that the effect's coefficient is recovered, and that
nothing is chosen on noisy data without an effect.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from diagnostics.discrepancy.balances import BalanceData, balance_data
from diagnostics.discrepancy.selection import select
from diagnostics.discrepancy.signals import prepare
from diagnostics.discrepancy.synthetic import DWELLS, NOISE, synthesize
from diagnostics.timeseries import SeriesRecord
from sim.components.effects import EFFECTS
from sim.rigs import load_rig, reference_rig, reference_rig_document
from sim.rigs.assembly import Condition

#: stated pump speed of the reference rig [rad/s]
SPEED = 1600.0 * 2.0 * math.pi / 60.0
ZERO = dict.fromkeys(NOISE, 0.0)
#: leak effects of the flow balances with a test strength (SI; ≈ 0.3 L/min at the
#: dwell's ≈ 73 bar, 6 σ of meter C): effect → (balance, coefficient, strength)
LEAKS: dict[str, tuple[str, str, float]] = {
    "turbulent_piston_leakage": ("chamber_flow", "K_t", 2e-9),
    "piston_clearance_pressure": ("chamber_flow", "k_c", 3e-21),
    "turbulent_spool_leakage": ("valve_flow", "K_t", 2e-9),
}
#: two dwell records of the bench design: 50 % speed at 40 °C, full speed at 40 °C
DESIGN = (DWELLS[0], DWELLS[2])


def _rig(effect: str | None = None) -> Any:
    doc: dict[str, Any] = reference_rig_document()
    if effect is not None:
        _, coef, k = LEAKS[effect]
        decl = EFFECTS[effect].parameter(coef)
        assert decl is not None
        doc["effects"] = {effect: {"parameters": {coef: {"value": k, "unit": decl.unit,
                                                         "source": "test"}}}}
    return load_rig(doc)


def _records(effect: str | None, seed: int | None) -> list[SeriesRecord]:
    rig = _rig(effect)
    rng = np.random.default_rng(0 if seed is None else seed)
    return [synthesize(rig, Condition(load=L, oil_temperature=T, pump_speed=f * SPEED),
                       rng=rng, name=f"dwell {f:.0%}", sigma=ZERO if seed is None else None,
                       t_max=sw) for L, T, f, sw in DESIGN]


def _data(records: list[SeriesRecord]) -> dict[str, BalanceData]:
    rig = reference_rig()
    s = prepare(records, rig)
    return {d.balance.name: d for d in balance_data(s, rig.values())}


def _still(records: list[SeriesRecord], d: BalanceData) -> np.ndarray:
    """Which kept rows of ``d`` are the piston at its stop (x within 6 mm of the end)."""
    rig = reference_rig()
    s = prepare(records, rig)
    return np.asarray((s.values["x"] > rig.values()["cylinder.stroke"] - 6e-3)[d.mask])


@pytest.fixture(scope="module")
def clean() -> dict[str | None, dict[str, BalanceData]]:
    return {e: _data(_records(e, None)) for e in (None, *LEAKS)}


def test_the_flow_balances_keep_the_held_samples_of_a_dwell() -> None:
    rig = reference_rig()
    s = prepare(_records(None, None), rig)
    data = {d.balance.name: d for d in balance_data(s, rig.values())}
    stroke = rig.values()["cylinder.stroke"]
    at_stop = s.values["x"] > stroke - 6e-3
    for name in ("chamber_flow", "valve_flow"):
        held = data[name].mask & at_stop
        # each record holds ≈ 1.5 s at its stop: > 1 s of it kept at 1 kHz in each
        for rec in range(len(DESIGN)):
            assert (held & (s.record == rec)).sum() > 1000
        assert np.all(np.abs(s.values["v"][held]) < 1e-4)  # standing
    # the force balance still leaves the stop out (its force is unmeasured)
    assert not np.any(data["piston_force"].mask & at_stop)


@pytest.mark.parametrize("effect", [None, *LEAKS])
def test_the_junctions_hold_exactly_on_a_held_piston(
        effect: str | None, clean: dict[str | None, dict[str, BalanceData]]) -> None:
    rig = reference_rig()
    v = rig.values()
    g_piston = math.pi * v["cylinder.bore"] * v["cylinder.cc"] ** 3 / (12.0 * v["cylinder.Lc"])
    g_spool = math.pi * v["valve.Dv"] * v["valve.cv"] ** 3 / (12.0 * v["valve.Ls"])
    for name, base, g in (("chamber_flow", "cylinder.cc (laminar)", g_piston),
                          ("valve_flow", "valve.cv (laminar)", g_spool)):
        d = clean[effect][name]
        # at the stop, and once the pressures stand (the compliance columns' rates below
        # 0.1 bar/s: the relief's pressure settles over the first ≈ 0.2 s of the hold)
        rates = [np.abs(d.base[k]) for k in ("hose_A compliance", "hose_B compliance")
                 if k in d.base]
        still = _still(_records(effect, None), d) & np.all([r < 1e4 for r in rates], axis=0)
        assert still.sum() > 2000
        pred = g * d.base[base][still]
        if effect is not None and LEAKS[effect][0] == name:
            pred = pred + LEAKS[effect][2] * d.candidates[effect][still]
        # hand calculation (laminar gap + the leak law at the measured Δp) to a tenth of the
        # flowmeter's σ (0.2 % of the leak): meter C is the piston leak, B − C the spool leak
        y = d.y[still]
        assert np.max(np.abs(y - pred)) < 0.1 * NOISE["Q_meter_C"]
        if effect is not None and LEAKS[effect][0] == name:
            extra = LEAKS[effect][2] * d.candidates[effect][still]
            assert np.min(np.abs(extra)) > 0.02 * np.max(np.abs(y))  # the leak shows there


@pytest.mark.parametrize("effect", list(LEAKS))
def test_the_leak_coefficient_is_recovered_by_least_squares(
        effect: str, clean: dict[str | None, dict[str, BalanceData]]) -> None:
    name, _, k = LEAKS[effect]
    d = clean[effect][name]
    X = np.column_stack([*d.base.values(), d.candidates[effect]])
    scale = np.sqrt(np.mean(X ** 2, axis=0))
    coef, *_ = np.linalg.lstsq(X / scale, d.y, rcond=None)
    assert coef[-1] / scale[-1] == pytest.approx(k, rel=0.02)
    # and without the effect its column is not needed
    d0 = clean[None][name]
    X0 = np.column_stack([*d0.base.values(), d0.candidates[effect]])
    s0 = np.sqrt(np.mean(X0 ** 2, axis=0))
    c0, *_ = np.linalg.lstsq(X0 / s0, d0.y, rcond=None)
    assert abs(c0[-1] / s0[-1]) < 0.02 * k


@pytest.mark.parametrize("seed", [11, 12])
def test_nothing_is_chosen_on_noisy_dwells_without_an_effect(seed: int) -> None:
    data = _data(_records(None, seed))
    for name in ("chamber_flow", "valve_flow"):
        assert select(data[name], bootstrap=0, seed=seed).chosen is None


def test_a_piston_leak_is_chosen_on_noisy_dwells() -> None:
    data = _data(_records("turbulent_piston_leakage", 13))
    sel = select(data["chamber_flow"], bootstrap=0, seed=13)
    assert sel.chosen is not None
    assert [t.effect for t in sel.chosen.terms] == ["turbulent_piston_leakage"]
    assert sel.chosen.terms[0].coefficient == pytest.approx(LEAKS[
        "turbulent_piston_leakage"][2], rel=0.2)
