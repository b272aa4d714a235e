"""The steady evaluator's derived observables against balances and kinematics."""

from __future__ import annotations

import numpy as np
import pytest

from sim.rigs import reference_rig
from sim.steady import SteadyEvaluator


def test_pump_flow_balance_speeds_and_durations_with_the_relief_open() -> None:
    """A relief set to 10 bar opens in the working stroke.  The pump's delivery is then
    metered flow plus relief flow, and by the balance at the pump outlet (steady: no
    compression) it is the geometric flow less the internal leak, ω·Vp − Pp/Rlp (paper 002
    eqs. 2, 5).  Speeds are positive in each phase's direction; a stroke takes stroke/speed;
    the velocity ratio is working over return speed (a mutation review: the relief flow
    left out of the pump flow, a negative return speed and stroke·speed passed)."""
    rig = reference_rig()
    ev = SteadyEvaluator(rig, rig.default_condition(), ("relief.Pset",))
    got = ev(np.array([10e5]))
    base = rig.base
    assert got["relief_flow"] > 0.05 * got["flow_B"]
    geometric = base["pump.speed"] * base["pump.Vp"]
    assert got["pump_flow"] == pytest.approx(
        geometric - got["pump_pressure"] / base["pump.Rlp"], rel=1e-6, abs=0)
    assert got["pump_flow"] == pytest.approx(geometric - got["pump_leak"], rel=1e-6, abs=0)
    stroke = base["cylinder.stroke"]
    assert got["speed_work"] > 0.0 and got["speed_return"] > 0.0
    assert got["duration_work"] == pytest.approx(stroke / got["speed_work"], rel=1e-12, abs=0)
    assert got["duration_return"] == pytest.approx(stroke / got["speed_return"], rel=1e-12,
                                                   abs=0)
    assert got["velocity_ratio"] == pytest.approx(got["speed_work"] / got["speed_return"],
                                                  rel=1e-12, abs=0)
