"""The field duty-cycle circuit (paper 000 §4): tables in, counting-meter flow out, gaps on demand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.components.gear_pump_map import stand_in_pump
from sim.duty_cycle import duty_cycle_model, rpm
from sim.errors import InputError

PUMP = stand_in_pump()
W = rpm(1467)


def ramp(t: np.ndarray, t0: float, t1: float, p0: float, p1: float) -> np.ndarray:
    """p0 until t0, a raised-cosine ramp to p1 at t1, then p1."""
    x = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    return p0 + (p1 - p0) * (0.5 - 0.5 * np.cos(np.pi * x))


def test_counting_meter_equals_the_steady_flow_on_plateaus_and_stores_oil_on_ramps():
    m = duty_cycle_model()
    t = np.arange(0.0, 8.0 + 1e-9, 0.03)
    p = ramp(t, 2.0, 2.3, 20e5, 135e5)
    th = np.linspace(40.0, 41.0, t.size)
    run = m.simulate(t, p, th, W, PUMP, rtol=1e-6)
    qs = m.quasi_static(t, p, th, W, PUMP)
    # after the ramp the hose columns ring (≈ 100 Hz, decay ≈ 0.7 s with their laminar R);
    # read every 30 ms, the ringing aliases to a slow wobble of ~0.1 % that dies out
    flat = (t > 1.0) & (t < 2.0) | (t > 6.0)
    np.testing.assert_allclose(run.q_meter[flat], qs[flat], rtol=2e-5)
    assert np.abs(run.q_meter / qs - 1)[(t > 2.5) & (t < 3.5)].max() < 3e-3
    # eq. 6 at the core pressure holds on the plateaus
    q6 = PUMP.flow(run.outputs["pump.p_core"], W, th)
    np.testing.assert_allclose(run.outputs["pump.Q"][flat], q6[flat], rtol=2e-5)
    # while the pressure rises, the hose and the outlet passage store oil: the meter reads
    # less than the steady flow, by about (C_hose2 + C_out)·dp/dt
    ramp_i = (t > 2.05) & (t < 2.25)
    assert np.all(run.q_meter[ramp_i] < qs[ramp_i])
    stored = np.sum((qs - run.q_meter) * 0.03)       # volume stored over the ramp [m³]
    c = math.pi / 4 * 0.0191**2 * 2.0 / 1.5e9 + 20e-6 / 1.5e9
    assert stored == pytest.approx(c * 115e5, rel=0.05)


def test_side_plate_lag_relaxes_with_its_time_constant():
    m = duty_cycle_model(("side_plate_lag",))
    t = np.arange(0.0, 4.0 + 1e-9, 0.01)
    p = ramp(t, 1.0, 1.05, 100e5, 110e5)
    th = np.full(t.size, 40.0)
    tau = 0.3
    run = m.simulate(t, p, th, W, PUMP, overrides={"side_plate_lag.tau": tau}, rtol=1e-7)
    static = PUMP.losses(run.outputs["pump.p_core"], W, th)[0]
    q_s = run.outputs["pump.Q_s"] - run.outputs["side_plate_lag.dQ_s"]   # net laminar slip
    dev = static - q_s                               # the slip lags behind the pressure
    assert np.all(dev[(t > 1.1) & (t < 2.0)] > 0.0)
    sel = (t > 1.3) & (t < 2.2)
    slope = np.polyfit(t[sel], np.log(dev[sel]), 1)[0]
    assert -1.0 / slope == pytest.approx(tau, rel=0.03)
    assert abs(dev[t > 3.9][0]) < 2e-4 * abs(static[-1])


def test_hysteresis_remembers_the_direction_of_the_last_change():
    m = duty_cycle_model(("slip_hysteresis",))
    t = np.arange(0.0, 6.0 + 1e-9, 0.01)
    p = ramp(t, 1.0, 1.3, 50e5, 120e5) + ramp(t, 3.5, 3.8, 0.0, -70e5)
    th = np.full(t.size, 40.0)
    h = 0.25
    run = m.simulate(t, p, th, W, PUMP, overrides={"slip_hysteresis.h": h}, rtol=1e-7)
    d = run.outputs["slip_hysteresis.direction"]
    # +1 after the rise, −1 after the fall (less the ringing's amplitude over the band)
    assert np.all(d[(t > 2.0) & (t < 3.5)] > 0.99) and np.all(d[t > 4.5] < -0.99)
    qs, qst, _ = PUMP.losses(run.outputs["pump.p_core"], W, th)
    net = run.outputs["pump.Q_s"] + run.outputs["pump.Q_st"] - run.outputs["slip_hysteresis.dQ"]
    np.testing.assert_allclose(net / (qs + qst), 1 + h * d, rtol=1e-9)
    # the same pressure (50 bar at the start, 50 bar at the end) gives two flows
    assert run.q_meter[-1] > run.q_meter[t < 0.9][-1]


def test_bad_inputs_are_refused():
    m = duty_cycle_model()
    with pytest.raises(InputError):
        m.simulate([0.0, 1.0], [1e6], [40.0, 40.0], W)
    with pytest.raises(InputError):
        m.simulate([0.0, 0.0, 1.0], [1e6] * 3, [40.0] * 3, W)
