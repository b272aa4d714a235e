"""The end-stop steady state (issue 11): a piston the load drives against its stroke sits
on its end stop, and the steady model gives that state, as the transient model settles.

Checks: the steady end-stop point against the settled values of :func:`sim.cycle.run_cycle`
(worn seal, hot, high load); hand balances at the stalled point (chamber 2 is fed only by
the piston leakage, the spool leakage is the difference of the meters, the Poiseuille
leakage at ``ẋ = 0``, the stop's reaction from the pressures and the load); with the
relief open, the relief flow is the pump's flow less the leakages; a moving piston is not
flagged and its point is the moving one; the evaluator gives speed 0 on the stop.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.cycle import phase_params, run_cycle
from sim.end_stop import held_state, stop_start
from sim.rigs import Condition, reference_rig
from sim.steady import SteadyEvaluator, steady_cycle, steady_phase, stop_force

#: a hot, worn seal at the paper's middle load: the working stroke stalls
STALLED = ({"cylinder.cc": 250e-6}, Condition(load=4200.0, oil_temperature=55.0))


def _settled(phase_rows: dict[str, np.ndarray], name: str) -> float:
    """Mean of the last quarter of a phase's samples (the settled stall)."""
    col = phase_rows[name]
    return float(np.mean(col[-max(col.size // 4, 2):]))


def test_stalled_working_stroke_matches_the_transients_settled_state() -> None:
    rig = reference_rig()
    ov, cond = STALLED
    sp = steady_phase(rig, "working", ov, cond)
    assert sp.end_stop and sp.outputs["v"] == 0.0 and sp.outputs["x"] == 0.0
    res = run_cycle(rig, ov, cond, timeseries=True)
    assert not res.working.completed
    ts = res.timeseries
    assert ts is not None
    rows = ts[ts["phase"] == "working"]
    cols = {c.split(" [")[0]: rows[c].to_numpy() for c in rows.columns if " [" in c}
    assert abs(_settled(cols, "v")) < 1e-6
    for name in ("P_pump", "P1", "P2", "Q_meter_B", "Q_meter_C", "Q_cyl_leak",
                 "Q_valve_leak", "Q_pump_leak", "Q_relief"):
        want = _settled(cols, name)
        scale = 1e5 if name.startswith("P") else 1e-6  # 1 bar, 1 ml/s
        assert sp.outputs[name] == pytest.approx(want, rel=2e-3, abs=1e-3 * scale), name


def test_stalled_point_balances_by_hand() -> None:
    rig = reference_rig()
    ov, cond = STALLED
    sp = steady_phase(rig, "working", ov, cond)
    o = sp.outputs
    m = rig.model
    p = phase_params(rig, "working", ov, cond)

    def par(name: str) -> float:
        return float(p[m.param_index(name)])

    # chamber 2 does not move: what meter C reads is the leakage past the piston, and it
    # is the Poiseuille flow at ẋ = 0 (paper 002 eq. 36, no Couette term)
    assert o["Q_meter_C"] == pytest.approx(o["Q_cyl_leak"], rel=1e-9)
    poiseuille = (math.pi * par("cylinder.bore") * par("cylinder.cc") ** 3 * (o["P1"] - o["P2"])
                  / (12.0 * par("fluid.mu") * par("cylinder.Lc")))
    assert o["Q_cyl_leak"] == pytest.approx(poiseuille, rel=1e-9)
    # line B feeds chamber 1's leakage and the spool's leakage to tank
    assert o["Q_meter_B"] - o["Q_meter_C"] == pytest.approx(o["Q_valve_leak"], rel=1e-6)
    # the stop holds what the pressures cannot: load − A1·P1 + A2·P2 (friction 0 at rest)
    reaction = par("load.force") - par("cylinder.A1") * o["P1"] + par("cylinder.A2") * o["P2"]
    assert sp.stop_reaction == pytest.approx(reaction, rel=1e-9)
    assert sp.stop_reaction > 0.0
    assert stop_force(rig, "working", sp.state, p) == pytest.approx(reaction, rel=1e-9)


def test_relief_takes_the_pump_flow_the_leaks_do_not() -> None:
    """A load beyond the relief setting (16 kN on 2.1e-3 m² needs 7.5 MPa > 7 MPa): the
    piston stalls with the relief open; relief flow = pump flow − leakages."""
    rig = reference_rig()
    cond = Condition(load=16000.0, oil_temperature=40.0)
    sp = steady_phase(rig, "working", None, cond)
    o = sp.outputs
    assert sp.end_stop and o["v"] == 0.0
    assert o["Q_relief"] > 1e-5
    assert o["P_pump"] > rig.base["relief.Pset"]
    pump_flow = o["Q_meter_B"] + o["Q_relief"]
    leaks = o["Q_cyl_leak"] + o["Q_valve_leak"]
    assert o["Q_relief"] == pytest.approx(pump_flow - leaks, rel=1e-6)
    res = run_cycle(rig, None, cond, timeseries=True)
    assert not res.working.completed
    ts = res.timeseries
    assert ts is not None
    rows = ts[ts["phase"] == "working"]
    tail = rows.iloc[-max(len(rows) // 4, 2):]
    assert o["Q_relief"] == pytest.approx(float(tail["Q_relief [m^3/s]"].mean()), rel=2e-3)
    assert o["P_pump"] == pytest.approx(float(tail["P_pump [Pa]"].mean()), rel=2e-3)


def test_a_moving_piston_is_not_held() -> None:
    rig = reference_rig()
    for phase in ("working", "return"):
        sp = steady_phase(rig, phase)
        assert not sp.end_stop and sp.stop_reaction == 0.0
        assert sp.speed > 0.05
    cyc = steady_cycle(rig)
    assert cyc.working.completed and cyc.return_.completed


def test_steady_cycle_and_evaluator_on_the_stop() -> None:
    rig = reference_rig()
    ov, cond = STALLED
    cyc = steady_cycle(rig, ov, cond)
    assert not cyc.working.completed
    assert cyc.working["speed"] == 0.0 and math.isinf(cyc.working["duration"])
    ev = SteadyEvaluator(rig, cond, ("cylinder.cc",))
    # along the clearance: moving, then held (continuation across the ridge both ways)
    ccs = [83e-6, 150e-6, 250e-6, 200e-6, 120e-6, 250e-6]
    for cc in ccs:
        got = ev(np.array([cc]))
        sp = steady_phase(rig, "working", {"cylinder.cc": cc}, cond)
        assert got["speed_work"] == pytest.approx(sp.outputs["v"], abs=1e-12)
        assert got["p1"] == pytest.approx(sp.outputs["P1"], rel=1e-8)
        assert got["flow_C"] == pytest.approx(sp.outputs["Q_meter_C"], rel=1e-8)
        if sp.end_stop:
            assert got["speed_work"] == 0.0 and got["velocity_ratio"] == 0.0
        else:
            assert got["speed_work"] > 0.0


def test_a_held_piston_pulled_off_its_stop_is_no_end_stop_state() -> None:
    """The healthy rig held at rest would push *off* its stop (the pressures overcome the
    load): that held state is refused (negative reaction), the moving point is the answer."""
    rig = reference_rig()
    cond = rig.default_condition()
    p = phase_params(rig, "working", None, cond)
    moving = steady_phase(rig, "working", None, cond)
    held = rig.model.steady(stop_start(rig, "working", moving.state, p), p,
                            frozen=("cylinder.x", "cylinder.mass"))
    assert stop_force(rig, "working", held, p) < -100.0  # pulls off by > 100 N
    assert held_state(rig, "working", p, [moving.state], 1e-10) is None

