"""Physics of the paper-002 rig model: balances, hand calculations, the paper's tables."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sim.bondgraph.elements import Kind
from sim.rigs import Condition, reference_rig
from sim.steady import steady_cycle, steady_phase

# paper 002 Table 3 (throttle I, 10 bar back-pressure) and Table 2 (throttle H), as
# repaired in shared/seeds/README.md, with their source and the tolerances these tests
# hold the rig to, each with its reason: one golden file for the tables
GOLDEN: dict[str, Any] = json.loads(
    (Path(__file__).parents[1] / "diagnostics" / "golden" / "throttle_tables.json")
    .read_text(encoding="utf-8"))
T3, T2 = GOLDEN["table3_valve"], GOLDEN["table2_cylinder"]


@pytest.fixture(scope="module")
def rig():
    return reference_rig()


def test_flow_and_effort_balance_at_every_junction_at_random_states(rig):
    m = rig.model
    g = m.system.graph
    rng = np.random.default_rng(7)
    p = rig.params(graph_values={"valve.N": 1.0})
    for _ in range(25):
        y = m.initial_state(p)
        for i, _name in enumerate(m.state_names):
            y[i] = rng.uniform(0, 5e6) if m.scale[i] == 1e5 else rng.normal() * 1e3 * m.scale[i]
        y[m.state_index("cylinder.x")] = rng.uniform(0, 0.5)
        e, f = m.bond_values(y, p)
        for el in g.elements.values():
            bonds = g.bonds_of(el.name)
            s = np.array([b.sign_at(el.name) for b in bonds], dtype=float)
            idx = [b.index for b in bonds]
            # both halves of each junction's law: a 0-junction's flows balance and its
            # bonds share one effort; a 1-junction's efforts balance and they share one flow
            if el.kind is Kind.ZERO:
                assert abs(s @ f[idx]) <= 1e-12 * np.abs(f[idx]).max() + 1e-20, el.name
                assert np.ptp(e[idx]) == 0.0, el.name
            elif el.kind is Kind.ONE:
                assert abs(s @ e[idx]) <= 1e-12 * np.abs(e[idx]).max() + 1e-9, el.name
                assert np.ptp(f[idx]) == 0.0, el.name
            elif el.kind in (Kind.TF, Kind.GY):
                b_in, b_out = g.two_port_bonds(el.name)
                assert e[b_in.index] * f[b_in.index] == pytest.approx(
                    e[b_out.index] * f[b_out.index], rel=1e-12, abs=1e-12)


def test_nominal_leakages_are_the_calibration_targets(rig):
    w = steady_phase(rig, "working").outputs
    assert w["Q_cyl_leak"] == pytest.approx(1.8e-5, rel=0.01)
    assert w["Q_valve_leak"] == pytest.approx(8.6e-6, rel=0.01)


def test_working_point_matches_a_hand_calculation(rig):
    """Every pressure and flow of the steady working point, recomputed from the laws."""
    b = rig.base
    v = rig.values()
    sp = steady_phase(rig, "working")
    o = sp.outputs
    area = math.pi * (0.06**2 - 0.03**2) / 4
    speed = o["v"]
    # force balance on the piston (eq. 28): (P1 - P2)·A = F + Fu·sgn(v) + Kf·v
    f_fric = b["cylinder.Fu"] + b["cylinder.Kf"] * speed
    assert (o["P1"] - o["P2"]) * area == pytest.approx(2100.0 + f_fric, rel=1e-6)
    # flow balance at the pump (eqs. 2, 5, 7): meter B = ω·Vp − Pp/Rlp − Qrv
    q_geo = b["pump.speed"] * b["pump.Vp"]
    assert o["Q_meter_B"] == pytest.approx(q_geo - o["P_pump"] / b["pump.Rlp"] - o["Q_relief"],
                                           rel=1e-9)
    # meter B − meter C = valve leakage (A1 = A2), meter C = A·v + Qlc (paper 002 §2.7)
    assert o["Q_meter_B"] - o["Q_meter_C"] == pytest.approx(o["Q_valve_leak"], rel=1e-6)
    assert o["Q_meter_C"] == pytest.approx(area * speed + o["Q_cyl_leak"], rel=1e-9)
    # piston leakage, Poiseuille − Couette (eq. 36, sign convention of sim.components.cylinder)
    mu = v["fluid.mu"]
    q_lc = (math.pi * 0.06 * 83e-6**3 * (o["P1"] - o["P2"]) / (12 * mu * b["cylinder.Lc"])
            - math.pi * 0.06 * 83e-6 * speed / 2)
    assert o["Q_cyl_leak"] == pytest.approx(q_lc, rel=1e-9)
    # pressure chain from the pump to chamber 1: PRpv, path P→A, hose A, check valve
    q_a = o["Q_meter_B"] - o["Q_valve_leak"]
    dp_path = (q_a / b["valve.K"]) ** 2
    dp_hose = 128 * mu * b["hose_A.L"] / (math.pi * b["hose_A.d"] ** 4) * q_a
    p1_hand = o["P_pump"] - b["supply_line.dp"] - dp_path - dp_hose - b["check.PRcv"]
    assert o["P1"] == pytest.approx(p1_hand, rel=2e-4)
    # valve leakage from the spool law (eq. 23)
    q_lv = math.pi * b["valve.Dv"] * 34e-6**3 * (o["P_valve_P"] - b["valve.PRvt"]) / (
        12 * mu * b["valve.Ls"])
    assert o["Q_valve_leak"] == pytest.approx(q_lv, rel=1e-9)


def test_without_leakage_the_piston_speed_is_the_pump_flow_over_the_area(rig):
    sc = steady_cycle(rig, {"cylinder.cc": 1e-7, "valve.cv": 1e-7, "pump.Rlp": 1e20})
    area = math.pi * (0.06**2 - 0.03**2) / 4
    q_geo = rig.base["pump.speed"] * rig.base["pump.Vp"]
    # what is left is the Couette drag of the 0.1 µm gap, π·D·c·v/2 ≈ 4e-6 of the flow
    assert sc.working["speed"] == pytest.approx(q_geo / area, rel=1e-5)
    assert sc.return_["speed"] == pytest.approx(q_geo / area, rel=1e-5)
    assert sc.velocity_ratio == pytest.approx(1.0, rel=1e-5)


def test_valve_leakage_follows_table_3(rig):
    """Calibrated at the closed row; ≥ 1 turn within 5 %, the ½-turn row within 15 %
    (the golden file's ``rig_tolerance_rel``, with its reason)."""
    for cv, q_table, tol in zip(T3["clearance_um"], T3["bypass_flow_m3_s"],
                                T3["rig_tolerance_rel"], strict=True):
        q = steady_phase(rig, "working", {"valve.cv": cv * 1e-6}).outputs["Q_valve_leak"]
        assert abs(q - q_table) / q_table < tol, (cv, q, q_table)


@pytest.mark.parametrize(("turns", "q_table"), list(zip(T3["turns"][1:],
                                                       T3["bypass_flow_m3_s"][1:], strict=True)))
def test_throttle_i_opened_passes_table_3_s_bypass_flow(rig, turns, q_table):
    """Throttle I emulates a worn spool (paper 002 §2.7): opened at 10 bar back-pressure
    (2.12 kN on the annulus), the bypass meter B − meter C is Table 3's within 5 % (its
    coefficient left the 1-2 turn rows 12-22 % low: a throttle technician's pass)."""
    cond = Condition(load=1e6 * rig.values()["cylinder.A2"], oil_temperature=40.0)
    w = steady_cycle(rig, {"throttle_I.opening": turns}, cond).working
    bypass = w["Q_meter_B"] - w["Q_meter_C"]
    assert abs(bypass - q_table) / q_table < T3["throttle_tolerance_rel"], (turns, bypass, q_table)


def test_cylinder_leakage_is_monotone_and_roughly_cubic(rig):
    legible = [c for c in T2["clearance_um"] if c is not None]
    cc = np.array([*legible, 160]) * 1e-6
    q = np.array([steady_phase(rig, "working", {"cylinder.cc": c}).outputs["Q_cyl_leak"]
                  for c in cc])
    assert np.all(np.diff(q) > 0)
    slope = np.polyfit(np.log(cc), np.log(q), 1)[0]
    assert 2.7 < slope < 3.3
    # within a factor 1.5 of Table 2's flows (a check of shape, not exact targets)
    table = np.array(T2["bypass_flow_m3_s"][: len(legible)])
    assert np.all(np.abs(np.log(q[: len(legible)] / table)) < np.log(T2["rig_flow_factor"]))


@pytest.mark.parametrize("key,grid", [("cylinder.cc", np.linspace(60e-6, 160e-6, 15)),
                                      ("valve.cv", np.linspace(20e-6, 80e-6, 15))])
def test_velocity_ratio_is_a_cubic_in_clearance(rig, key, grid):
    ratio = np.array([steady_cycle(rig, {key: c}).velocity_ratio for c in grid])
    assert np.all(np.diff(ratio) < 0), "more clearance, slower working phase"
    # paper 002 fits the ratio by a 3rd-degree polynomial in the clearance: the cubic must
    # follow the model to the solver's tolerance (max residual 5.7e-5 cc, 5.0e-5 cv) and
    # its cubic term must matter (a quadratic misses by 3.1e-3 / 3.9e-3); a correlation of
    # the fit with the ratio passed a quadratic and a non-polynomial law alike (a review)
    x = grid * 1e6
    cubic = np.abs(np.polyval(np.polyfit(x, ratio, 3), x) - ratio).max()
    quadratic = np.abs(np.polyval(np.polyfit(x, ratio, 2), x) - ratio).max()
    assert cubic < 2e-4
    assert quadratic > 10 * cubic


def test_heavier_load_means_higher_pressure_more_leakage_lower_ratio(rig):
    rows = [steady_cycle(rig, None, Condition(load=f)) for f in (2.1e3, 4.2e3, 6.3e3)]
    p = [r.working["P_pump"] for r in rows]
    q = [r.working["Q_cyl_leak"] for r in rows]
    ratio = [r.velocity_ratio for r in rows]
    assert p[0] < p[1] < p[2] and q[0] < q[1] < q[2] and ratio[0] > ratio[1] > ratio[2]
    # 2.1 kN more load adds 2.1 kN / A to the chamber pressure difference
    area = math.pi * (0.06**2 - 0.03**2) / 4
    dp = [r.working["P1"] - r.working["P2"] for r in rows]
    assert dp[1] - dp[0] == pytest.approx(2.1e3 / area, rel=0.01)


def test_relief_valve_limits_the_pressure(rig):
    sp = steady_phase(rig, "working", {"relief.Pset": 3.0e6}, Condition(load=6.3e3))
    o = sp.outputs
    assert o["Q_relief"] > 0
    assert o["P_pump"] == pytest.approx(3.0e6 + o["Q_relief"] * rig.base["relief.Rrv"], rel=1e-6)
