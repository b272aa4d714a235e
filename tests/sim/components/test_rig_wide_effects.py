"""Effects that change a property or an existing element's law: the viscosity–temperature
law, the relief-valve override, entrained air and unsteady line friction (issue 8).

Each: zero strength gives the base rig bit for bit (right-hand side and a simulation),
the changed element obeys the hand-computed law inside the compiled model, and the law's
own physics (round trips) holds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from sim.components.cylinder import chamber_capacitance, piston_leakage_flow
from sim.components.effects import get_effect
from sim.components.effects.entrained_air import air_capacitance, air_compliance_factor
from sim.components.effects.line_unsteady_friction import scaled_inertance
from sim.components.effects.relief_override import override_flow
from sim.components.effects.viscosity_law import viscosity_factor
from sim.components.relief_valve import relief_flow
from sim.rigs import load_rig, reference_rig, reference_rig_document
from sim.rigs.assembly import Condition, Rig

NEW = {"viscosity_law": "lam", "relief_override": "k_ov", "entrained_air": "alpha",
       "line_unsteady_friction": "k3"}


def _rig(name: str, value: float | None) -> Rig:
    doc = reference_rig_document()
    e = get_effect(name)
    pname = NEW[name]
    unit = e.parameter(pname).unit  # type: ignore[union-attr]
    body = {} if value is None else {"parameters": {pname: {"value": value, "unit": unit}}}
    doc["effects"] = {name: body}
    return load_rig(doc)


def _state(rig: Rig, rng: np.random.Generator, p: np.ndarray) -> np.ndarray:
    m = rig.model
    y = m.initial_state(p)
    for i in range(len(m.state_names)):
        y[i] = rng.uniform(0, 9e6) if m.scale[i] == 1e5 else rng.normal() * 1e3 * m.scale[i]
    y[m.state_index("cylinder.x")] = rng.uniform(0.01, 0.49)
    return y


@pytest.mark.parametrize("name", list(NEW))
def test_zero_strength_leaves_the_right_hand_side_unchanged_bit_for_bit(name):
    base, zero = reference_rig(), _rig(name, 0.0)
    cond = Condition(load=4200.0, oil_temperature=60.0)
    pb = base.params(condition=cond, graph_values={"valve.N": 1.0})
    pz = zero.params(condition=cond, graph_values={"valve.N": 1.0})
    assert base.model.state_names == zero.model.state_names
    rng = np.random.default_rng(11)
    for _ in range(20):
        y = _state(base, rng, pb)
        np.testing.assert_array_equal(zero.model.derivative(y, pz), base.model.derivative(y, pb))


def test_zero_strength_simulates_the_base_cycle_bit_for_bit():
    from diagnostics.discrepancy.simulate import simulate

    cond = Condition(load=2100.0, oil_temperature=50.0)
    base = simulate(reference_rig(), cond)
    for name in NEW:
        out = simulate(_rig(name, None), cond)
        assert list(out.columns) == list(base.columns)
        np.testing.assert_array_equal(out.iloc[:, 2:].to_numpy(), base.iloc[:, 2:].to_numpy())


# -- viscosity–temperature law ------------------------------------------------------------

def test_viscosity_law_rescales_mu_and_every_viscous_coefficient_by_the_hand_factor():
    lam = 0.012
    rig, base = _rig("viscosity_law", lam), reference_rig()
    for T in (40.0, 60.0, 80.0):
        cond = Condition(oil_temperature=T)
        v, b = rig.values(condition=cond), base.values(condition=cond)
        factor = math.exp(-lam * (T - 40.0))
        assert viscosity_factor(T, lam, 40.0) == pytest.approx(factor, rel=1e-15)
        assert v["fluid.mu"] == pytest.approx(b["fluid.mu"] * factor, rel=1e-14)
        # Hagen-Poiseuille R of the hoses derives from the corrected μ
        assert v["hose_A.R"] == pytest.approx(b["hose_A.R"] * factor, rel=1e-14)
    # at the reference temperature the stated law is right
    assert rig.values()["fluid.mu"] == base.values()["fluid.mu"]


def test_viscosity_law_piston_leak_in_the_model_is_eq36_with_the_true_viscosity():
    lam = 0.015
    rig = _rig("viscosity_law", lam)
    cond = Condition(load=6300.0, oil_temperature=60.0)
    p = rig.params(condition=cond, graph_values={"valve.N": 1.0})
    m, g = rig.model, rig.model.system.graph
    y = m.initial_state(p)
    P1, P2, vel = 5.0e6, 0.8e6, 0.1
    for el, val in (("cylinder.C1", P1), ("cylinder.C2", P2), ("cylinder.mass", vel)):
        y[m.state_names.index(el)] = val
    y[m.state_index("cylinder.x")] = 0.25
    _, f = m.bond_values(y, p)
    (bond,) = g.bonds_of("cylinder.Rlc")
    vals = reference_rig().values(condition=cond)
    mu_true = vals["fluid.mu"] * math.exp(-lam * 20.0)
    hand = piston_leakage_flow(P1 - P2, vel, vals["cylinder.cc"], vals["cylinder.bore"],
                               vals["cylinder.Lc"], mu_true)
    assert f[bond.index] == pytest.approx(hand, rel=1e-12)
    # and 1/μ grew by exp(λ·ΔT) ≈ 35 %: the leak is not the stated one
    stated = piston_leakage_flow(P1 - P2, vel, vals["cylinder.cc"], vals["cylinder.bore"],
                                 vals["cylinder.Lc"], vals["fluid.mu"])
    assert hand / stated > 1.3


def test_viscosity_law_regressor_is_the_first_order_excess_leak():
    from diagnostics.discrepancy.signals import stated_coefficients

    lam = 1e-3
    vals = reference_rig().values(condition=Condition(oil_temperature=60.0))
    G = stated_coefficients(vals)["G_piston"]
    dp = np.array([1e6, 3e6])
    s = {"T": np.full(2, 60.0), "P1": dp, "P2": np.zeros(2), "mu": np.full(2, vals["fluid.mu"]),
         "G_piston": np.full(2, G)}
    col = get_effect("viscosity_law").entry.regressor(s)
    exact = G * dp / (vals["fluid.mu"] * viscosity_factor(60.0, lam, 40.0)) - G * dp / vals[
        "fluid.mu"]
    np.testing.assert_allclose(lam * col, exact, rtol=0.011)  # first order: λΔT = 0.02


# -- relief-valve override ----------------------------------------------------------------

def test_override_law_round_trips_its_pressure_flow_line_and_reduces_to_eq6():
    pset, rrv, k = 7.0e6, 2.5e9, 4.0e12
    for d in (1e3, 5e5, 1.2e6, 3e6):
        q = override_flow(pset + d, pset, rrv, 0.0, k)
        assert rrv * q + k * q * q == pytest.approx(d, rel=1e-12)
        assert override_flow(pset + d, pset, rrv, 0.0, 0.0) == relief_flow(pset + d, pset, rrv,
                                                                           0.0)
        # less flow at the same pressure: the line rises more steeply
        assert q < d / rrv
    assert override_flow(pset - 1.0, pset, rrv, 0.0, k) == 0.0
    assert override_flow(5e6, pset, rrv, 1e-12, k) == pytest.approx(5e-6, rel=1e-15)


def test_relief_override_in_the_model_flows_by_the_law_and_only_dissipates():
    k = 4.0e12
    rig = _rig("relief_override", k)
    p = rig.params(graph_values={"valve.N": 1.0})
    m, g = rig.model, rig.model.system.graph
    (bond,) = g.bonds_of("relief")
    v = rig.values()
    rng = np.random.default_rng(5)
    opened = 0
    for _ in range(30):
        y = _state(rig, rng, p)
        e, f = m.bond_values(y, p)
        pp = e[bond.index]
        assert f[bond.index] == pytest.approx(
            override_flow(pp, v["relief.Pset"], v["relief.Rrv"], v["relief.Gseat"], k),
            rel=1e-12, abs=1e-20)
        assert e[bond.index] * f[bond.index] >= 0.0
        opened += pp > v["relief.Pset"]
    assert opened >= 5


# -- entrained air ------------------------------------------------------------------------

def test_air_capacitance_is_the_polytropic_gas_compliance_plus_the_liquid():
    V0, A, x, beta, n, pa, alpha = 5e-5, 2.12e-3, 0.2, 1.5e9, 1.4, 101325.0, 0.01
    vol = V0 + A * x
    assert air_capacitance(V0, A, x, 0.0, 1.0, beta, 3e6, 0.0, n, pa) == chamber_capacitance(
        V0, A, x, 0.0, 1.0, beta)
    for p in (0.0, 1e5, 1e6, 5e6):
        c = air_capacitance(V0, A, x, 0.0, 1.0, beta, p, alpha, n, pa)
        pabs = p + pa
        assert c == pytest.approx(vol / beta + alpha * vol * (pa / pabs) ** (1 / n) / (n * pabs),
                                  rel=1e-13)

    # round trip: the compliance integrates to the volume the gas loses between two
    # pressures, V_g(p) = α0·V·(p_a/p_abs)^(1/n)
    def gas_volume(p: float) -> float:
        return alpha * vol * (pa / (p + pa)) ** (1 / n)

    lost, _ = quad(lambda p: alpha * vol * air_compliance_factor(p, n, pa), 2e5, 4e6)
    assert lost == pytest.approx(gas_volume(2e5) - gas_volume(4e6), rel=1e-9)


def test_effective_bulk_modulus_falls_at_low_pressure():
    V0, A, x, beta = 5e-5, 2.12e-3, 0.2, 1.5e9
    vol = V0 + A * x

    def beta_eff(p: float) -> float:
        return vol / air_capacitance(V0, A, x, 0.0, 1.0, beta, p, 0.005, 1.4, 101325.0)

    # 0.5 % free air at 2 bar gauge: 1/β_e = 1/β + α0·(p_a/p_abs)^(1/n)/(n·p_abs) by hand,
    # p_abs = 3.013 bar: (0.33626)^0.71429 / (1.4 × 3.01325e5) = 1.0883e-6 1/Pa
    hand = 1.0 / (1.0 / beta + 0.005 * 1.0883e-6)
    assert beta_eff(2e5) == pytest.approx(hand, rel=1e-3)
    assert beta_eff(2e5) < 0.12 * beta  # ≈ 11 % of the liquid's
    assert beta_eff(1e7) > 0.9 * beta
    assert beta_eff(2e5) < beta_eff(1e6) < beta_eff(1e7)


def test_entrained_air_chamber_pressures_rise_by_flow_over_the_air_capacitance():
    alpha = 2e-3
    rig = _rig("entrained_air", alpha)
    p = rig.params(graph_values={"valve.N": 1.0})
    m, g = rig.model, rig.model.system.graph
    v = rig.values()
    rng = np.random.default_rng(9)
    i1, i2 = m.state_names.index("cylinder.C1"), m.state_names.index("cylinder.C2")
    (b1,) = g.bonds_of("cylinder.C1")
    (b2,) = g.bonds_of("cylinder.C2")
    for _ in range(10):
        y = _state(rig, rng, p)
        x = y[m.state_index("cylinder.x")]
        _, f = m.bond_values(y, p)
        dy = m.derivative(y, p)
        c1 = air_capacitance(v["cylinder.V01"], v["cylinder.A1"], x, 0.0, 1.0,
                             v["fluid.beta"], y[i1], alpha, 1.4, 101325.0)
        c2 = air_capacitance(v["cylinder.V02"], v["cylinder.A2"], x, v["cylinder.stroke"], -1.0,
                             v["fluid.beta"], y[i2], alpha, 1.4, 101325.0)
        assert dy[i1] == pytest.approx(f[b1.index] / c1, rel=1e-12)
        assert dy[i2] == pytest.approx(f[b2.index] / c2, rel=1e-12)


# -- unsteady line friction ---------------------------------------------------------------

def test_line_friction_scales_both_hose_inertances_in_the_model():
    k3 = 0.08
    rig = _rig("line_unsteady_friction", k3)
    p = rig.params(graph_values={"valve.N": 1.0})
    m, g = rig.model, rig.model.system.graph
    v = rig.values()
    rng = np.random.default_rng(2)
    assert scaled_inertance(3.0e6, 0.0) == 3.0e6
    for _ in range(10):
        y = _state(rig, rng, p)
        e, _ = m.bond_values(y, p)
        dy = m.derivative(y, p)
        for hose in ("hose_A", "hose_B"):
            (b,) = g.bonds_of(f"{hose}.I")
            i = m.state_names.index(f"{hose}.I")
            # the oil column ρ·L/A, hand computed
            inertance = v["fluid.rho"] * v[f"{hose}.L"] / (math.pi * v[f"{hose}.d"] ** 2 / 4)
            assert dy[i] == pytest.approx(e[b.index] / ((1 + k3) * inertance), rel=1e-12)
