"""The gear pump as a bond graph (paper 000 Figure 7) against the pure eq. 6 / eq. 16 model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.bondgraph import BondGraph
from sim.components import gear_pump_laws as laws
from sim.components.gear_pump import CoefficientSurface
from sim.components.gear_pump_fragment import build, pump_values, surface_values
from sim.components.gear_pump_map import stand_in_pump
from sim.duty_cycle import duty_cycle_model
from sim.errors import ParameterError

RPM = 2 * math.pi / 60
PUMP = stand_in_pump()


@pytest.fixture(scope="module")
def circuit():
    """The duty-cycle circuit (pump + hoses + relief + pressure source), compiled once."""
    return duty_cycle_model()


def steady(circuit, dp: float, rpm: float, theta: float, pump=PUMP):
    """Steady state at an imposed system pressure ``dp`` [Pa] (constant tables)."""
    w = rpm * RPM
    p = circuit.params(np.array([0.0, 1.0]), np.full(2, dp), np.full(2, theta), w, pump)
    y = circuit.initial_state(p, dp, pump.D * w)
    out = circuit.model.outputs(np.zeros(1), y[None, :], p)[0]
    return dict(zip(circuit.model.output_names, out, strict=True)), y, p, w


GRID = [(dp, n, th) for dp in (20e5, 90e5, 160e5, 250e5) for n in (600, 1467, 2400)
        for th in (22.0, 60.0)]


def test_steady_flow_and_torque_equal_eq6_and_eq16_over_a_grid(circuit):
    for dp, n, th in GRID:
        o, _, _, w = steady(circuit, dp, n, th)
        pc = o["pump.p_core"]
        assert pc > dp  # the hoses and the outlet passage drop pressure towards the block
        q_ref = float(PUMP.flow(pc, w, th))
        t_ref = float(PUMP.torque(pc, w, th))
        assert o["pump.Q"] == pytest.approx(q_ref, rel=1e-9), (dp, n, th)
        assert o["pump.torque"] == pytest.approx(t_ref, rel=1e-9), (dp, n, th)
        assert o["Q_meter"] == pytest.approx(q_ref, rel=1e-9)       # no storage at steady state
        assert o["pump.p_out"] < pc                                  # the outlet passage drop
        qs, qst, qc = PUMP.losses(pc, w, th)
        assert o["pump.Q_s"] == pytest.approx(float(qs), rel=1e-9)
        assert o["pump.Q_st"] == pytest.approx(float(qst), rel=1e-9)
        assert o["pump.Q_c"] == pytest.approx(float(qc), rel=1e-9)
        assert o["pump.Q_ideal"] == pytest.approx(PUMP.D * w, rel=1e-12)


def test_power_balance_shaft_to_hydraulic_plus_losses(circuit):
    g = circuit.model.system.graph
    label = {b.label: b.index for b in g.bonds if b.label}
    for dp, n, th in GRID[::5]:
        o, y, p, w = steady(circuit, dp, n, th)
        e, f = circuit.model.bond_values(y, p)
        shaft = e[label["pump.shaft_in"]] * f[label["pump.shaft_in"]]
        assert f[label["pump.shaft_in"]] == pytest.approx(w, rel=1e-15)
        losses = {k: e[label[f"pump.{k}"]] * f[label[f"pump.{k}"]]
                  for k in ("visc", "coul", "lamin", "turb", "comp", "rout")}
        # every loss absorbs power, except the laminar slip where the map's Cs < 0 (Couette
        # drag exceeds Poiseuille slip at high speed and low pressure, paper 000 §3.1)
        cs = float(PUMP.Cs(o["pump.p_core"], w))
        assert all(v > 0.0 for k, v in losses.items() if k != "lamin")
        assert np.sign(losses["lamin"]) == np.sign(cs)
        hydraulic = o["pump.p_out"] * o["pump.Q"]
        assert shaft == pytest.approx(hydraulic + sum(losses.values()), rel=1e-9)
        # and the pump's efficiencies are eq. 6 / eq. 16's
        eta = hydraulic / shaft
        pc = o["pump.p_core"]
        eta_ref = (pc * float(PUMP.flow(pc, w, th))) / (float(PUMP.torque(pc, w, th)) * w)
        assert eta == pytest.approx(eta_ref * o["pump.p_out"] / pc, rel=1e-9)


def test_a_worn_pump_is_a_parameter_override_not_a_new_graph(circuit):
    cs = PUMP.Cs
    worn = type(PUMP)(Cs=CoefficientSurface(3.0 * cs.coef), Cst=PUMP.Cst, Cv=PUMP.Cv,
                      Cf=PUMP.Cf)
    o_new, *_ = steady(circuit, 135e5, 1467, 50.0)
    o_worn, *_ = steady(circuit, 135e5, 1467, 50.0, pump=worn)
    qs = PUMP.losses(o_worn["pump.p_core"], 1467 * RPM, 50.0)[0]
    assert o_worn["pump.Q_s"] == pytest.approx(3.0 * float(qs), rel=1e-9)
    assert o_worn["pump.Q"] < o_new["pump.Q"]


def test_surface_parameters_round_trip_and_degree_limit():
    rng = np.random.default_rng(0)
    for k in ("Cs", "Cst", "Cv", "Cf"):
        surf = getattr(PUMP, k)
        c = surface_values(surf)
        for dp, w in zip(rng.uniform(0, 3e7, 20), rng.uniform(30, 260, 20), strict=True):
            got = laws.surface_value(dp, w, surf.p_ref, surf.omega_ref, *c)
            assert got == pytest.approx(float(surf(dp, w)), rel=1e-12, abs=1e-24)
    with pytest.raises(ParameterError):
        surface_values(CoefficientSurface(np.ones((5, 1))))
    v = pump_values(PUMP, "p")
    assert v["p.Cs.c33"] == PUMP.Cs.coef[3, 3] and v["p.Cv.c22"] == 0.0
    with pytest.raises(ParameterError, match=r"fluid\.mu"):
        build(BondGraph("no-fluid"), "pump")


def test_the_play_operator_of_the_hysteresis_memory():
    assert laws.play_rate(2e5, 3e5, 0.02) == 0.0
    assert laws.play_rate(5e5, 3e5, 0.02) == pytest.approx(2e5 / 0.02)
    assert laws.play_rate(-5e5, 3e5, 0.02) == pytest.approx(-2e5 / 0.02)
