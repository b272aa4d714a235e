"""Library effects of the paper-000 field circuit: side-plate lag and slip hysteresis.

Each element is checked against its law by hand, its junction balance, 'zero strength =
base model' (the right-hand side bit for bit) and the step response a first-order lag must
have (the duty-cycle tests check the relaxation of the slip and the hysteresis gain).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.bondgraph.elements import Kind
from sim.components.effects import EFFECTS, effects_for, get_effect
from sim.components.effects.base import FIELD_CIRCUIT
from sim.components.gear_pump_laws import laminar_slip, turbulent_slip
from sim.components.gear_pump_map import stand_in_pump
from sim.duty_cycle import duty_cycle_model, rpm
from sim.errors import RigFileError

PUMP = stand_in_pump()
W = rpm(1467)
LIB = ("side_plate_lag", "slip_hysteresis")


@pytest.fixture(scope="module")
def models():
    return duty_cycle_model(), duty_cycle_model(LIB)


def _record(t_end: float = 6.0, dt: float = 0.01):
    t = np.arange(0.0, t_end + dt / 2, dt)
    p = np.where((t >= 2.0) & (t < 4.0), 135e5, 20e5)
    return t, p, np.full(t.size, 45.0)


def _params(m, overrides=None):
    t, p, th = _record()
    return m.params(t + 0.01, p, th, W, PUMP, overrides)


def test_entries_belong_to_the_field_circuit_and_are_off_by_default():
    field = effects_for(FIELD_CIRCUIT)
    assert set(field) == set(LIB)
    for name, e in field.items():
        assert EFFECTS[name] is e and e.entry.balance == "field_flow"
        assert e.parameter(e.entry.coefficient).default == 0.0
        assert e.entry.reference.startswith("paper 000")
    assert get_effect("slip_hysteresis").frozen == ("slip_hysteresis.m",)
    assert "side_plate_lag" not in effects_for("pump-valve-cylinder")
    with pytest.raises(RigFileError):
        duty_cycle_model(("couette_drag",))


def test_zero_strength_gives_the_base_right_hand_side_bit_for_bit(models):
    base, lib = models
    pb, pl = _params(base), _params(lib)
    rng = np.random.default_rng(1)
    nb = len(base.model.state_names)
    assert lib.model.state_names[:nb] == base.model.state_names
    for _ in range(20):
        yb = base.initial_state(pb, 20e5, PUMP.D * W)
        yb = yb * rng.uniform(0.5, 1.5, yb.size)
        yl = np.concatenate([yb, rng.uniform(0.0, 2e7, 2)])
        t = float(rng.uniform(0.0, 6.0))
        np.testing.assert_array_equal(lib.model.derivative(yl, pl, t)[:nb],
                                      base.model.derivative(yb, pb, t))


def test_sources_follow_their_laws_and_the_core_junction_balances(models):
    _, lib = models
    p = _params(lib, {"side_plate_lag.tau": 0.3, "slip_hysteresis.h": 0.2})
    g = lib.model.system.graph
    y = lib.initial_state(p, 100e5, PUMP.D * W)
    i_core = lib.model.state_index("pump.compr")
    dp, p_sp, mem = 120e5, 90e5, 110e5
    y[i_core] = dp
    y[lib.model.state_index("side_plate_lag.p_sp")] = p_sp
    y[lib.model.state_index("slip_hysteresis.m")] = mem
    t = 1.0
    e, f = lib.model.bond_values(y, p, t)
    v = {k: p[lib.model.param_index(k)] for k in g.parameters}
    mu = PUMP.fluid.dynamic_viscosity(45.0)
    cs = [v[f"pump.Cs.c{i}{j}"] for i in range(4) for j in range(4)]
    cst = [v[f"pump.Cst.c{i}{j}"] for i in range(4) for j in range(4)]
    tbl = np.array([0.0, 1.0, 2.0, mu, mu, mu])    # a constant viscosity table by hand

    def qs(x: float) -> float:
        return laminar_slip(x, W, 0.5, tbl, 0, 3, v["pump.D"], v["pump.Cs.p_ref"],
                            v["pump.Cs.omega_ref"], *cs)

    def qst(x: float) -> float:
        return turbulent_slip(x, W, v["pump.rho"], v["pump.D"], v["pump.dp_s"],
                              v["pump.Cst.p_ref"], v["pump.Cst.omega_ref"], *cst)

    def flow(el: str) -> float:
        (b,) = g.bonds_of(el)
        return float(f[b.index])

    assert flow("side_plate_lag.lam") == pytest.approx(qs(dp) - qs(p_sp), rel=1e-12)
    assert flow("side_plate_lag.turb") == pytest.approx(qst(dp) - qst(p_sp), rel=1e-12)
    s = min(1.0, max(-1.0, (dp - mem) / 3e5))          # 10 bar above the memory: rising
    assert flow("slip_hysteresis.Sf") == pytest.approx(-0.2 * s * (qs(dp) + qst(dp)), rel=1e-12)
    # lag state: dp_sp/dt = (Δp − p_sp)/τ; memory: the play leaves the band at rate (e − w)/τ_h
    d = lib.model.derivative(y, p, t)
    assert d[lib.model.state_index("side_plate_lag.p_sp")] == pytest.approx((dp - p_sp) / 0.3)
    assert d[lib.model.state_index("slip_hysteresis.m")] == pytest.approx(
        (dp - mem - 3e5) / 0.02)
    # every 0-junction: Σ flows = 0; every 1-junction: Σ efforts = 0
    for el in g.elements.values():
        bonds = g.bonds_of(el.name)
        sg = np.array([b.sign_at(el.name) for b in bonds], dtype=float)
        idx = [b.index for b in bonds]
        if el.kind is Kind.ZERO:
            assert abs(sg @ f[idx]) <= 1e-12 * np.abs(f[idx]).max(), el.name
        elif el.kind is Kind.ONE:
            assert abs(sg @ e[idx]) <= 1e-12 * np.abs(e[idx]).max() + 1e-9, el.name


def test_lag_excess_flow_decays_with_the_time_constant_after_a_small_step():
    m = duty_cycle_model(("side_plate_lag",))
    base = duty_cycle_model()
    t = np.arange(0.0, 4.0 + 0.005, 0.01)
    # a 5 bar raised-cosine step over 0.2 s (the slip is locally linear in Δp; a sharp
    # step would ring the lightly damped hoses)
    x = np.clip((t - 1.0) / 0.2, 0.0, 1.0)
    p = 100e5 + 5e5 * (0.5 - 0.5 * np.cos(np.pi * x))
    th = np.full(t.size, 45.0)
    tau = 0.4
    a = m.simulate(t, p, th, W, PUMP, overrides={"side_plate_lag.tau": tau}, rtol=1e-8)
    b = base.simulate(t, p, th, W, PUMP, rtol=1e-8)
    excess = a.outputs["pump.Q"] - b.outputs["pump.Q"]
    # after the ramp the linear(ised) system relaxes: excess(t) = excess(t1)·exp(−(t − t1)/τ)
    k1, k2 = np.searchsorted(t, [1.4, 2.6])
    assert excess[k1] > 0.0                          # more flow while the plates lag
    assert math.log(excess[k1] / excess[k2]) / (t[k2] - t[k1]) == pytest.approx(1 / tau,
                                                                                rel=0.02)
    # zero strength: the same trajectory as the base model within the solver tolerance
    z = m.simulate(t, p, th, W, PUMP, rtol=1e-8)
    np.testing.assert_allclose(z.q_meter, b.q_meter, rtol=1e-6)
