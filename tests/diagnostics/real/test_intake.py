"""The accumulator's intake on a plateau: hand calculations, a synthetic round trip, a slice."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import trapezoid

from diagnostics.real.accumulator import step_volumes
from diagnostics.real.leakage import cycle_point
from diagnostics.real.precharge import (
    cycle_precharges,
    fit_precharge,
    stored_rate,
    stored_volume,
)
from diagnostics.real.profile import plateau_deficits, plateau_table, profile_sizes
from diagnostics.real.scoring import score_classes
from diagnostics.real.shunt import shunt_estimates
from diagnostics.real.zema import load_1hz, read_records
from diagnostics.timeseries import SeriesRecord
from sim.components.gear_pump import dynamic_viscosity
from sim.errors import InputError
from sim.fluid import Fluid
from tests.real_slices import zema_slice

BAR = 1.0e5
LPM = 1.0 / 60000.0


def test_stored_rate_by_hand() -> None:
    # isothermal, 1 l filled to 100 bar: S(p) = V0·(1 − p0/p); at 2 Hz
    p = np.array([200.0, 201.0, 203.0, 203.0]) * BAR
    r = stored_rate(p, 100 * BAR, 1e-3, 2.0, n=1.0)

    def s(x: float) -> float:
        return 1e-3 * (1.0 - 100.0 / x)

    assert r[0] == pytest.approx((s(201) - s(200)) * 2.0)  # one-sided at the start
    assert r[1] == pytest.approx((s(203) - s(200)) / 2 * 2.0)  # central inside
    assert r[3] == pytest.approx(0.0)  # one-sided at the end, steady there
    # a steady plateau, or one below the pre-charge (empty accumulator), takes in nothing
    assert np.all(stored_rate(np.full(5, 150 * BAR), 100 * BAR, 1e-3, 1.0) == 0.0)
    assert np.all(stored_rate(np.array([80.0, 85.0, 90.0]) * BAR, 100 * BAR, 1e-3, 1.0) == 0.0)
    # the rates integrate back to the stored volume of a ramp
    ramp = np.linspace(150.0, 160.0, 101) * BAR
    rate = stored_rate(ramp, 120 * BAR, 0.6e-3, 10.0)
    assert float(trapezoid(rate, dx=0.1)) == pytest.approx(
        float(stored_volume(150 * BAR, 160 * BAR, 120 * BAR, 0.6e-3)), rel=1e-3)
    with pytest.raises(InputError):
        stored_rate(p[:1], 100 * BAR, 1e-3, 1.0)
    with pytest.raises(InputError):
        stored_rate(p, float("nan"), 1e-3, 1.0)
    with pytest.raises(InputError):
        stored_rate(p, 100 * BAR, 1e-3, 0.0)


def test_cycles_without_a_fit_take_the_nearest_cycles_fill_at_their_own_temperature() -> None:
    p0 = np.array([np.nan, 120.0, np.nan, np.nan, 130.0]) * BAR
    theta = np.array([40.0, 20.0, 30.0, 60.0, 20.0])
    out = cycle_precharges(p0, theta)
    assert out[1] == pytest.approx(120 * BAR) and out[4] == pytest.approx(130 * BAR)
    assert out[0] == pytest.approx(120 * BAR * 313.15 / 293.15)  # from cycle 1, at 40 °C
    assert out[2] == pytest.approx(120 * BAR * 303.15 / 293.15)  # cycle 1 is nearer than 4
    assert out[3] == pytest.approx(130 * BAR * 333.15 / 293.15)  # cycle 4 is nearer than 1
    # a neighbour fitted hot is referred through the fill temperature
    hot = cycle_precharges(np.array([140.0 * BAR, np.nan]), np.array([50.0, 20.0]))
    assert hot[1] == pytest.approx(140 * BAR * 293.15 / 323.15)
    with pytest.raises(InputError):
        cycle_precharges(np.full(3, np.nan), np.full(3, 20.0))
    with pytest.raises(InputError):
        cycle_precharges(p0, theta[:4])


def _drifting(name: str, q_pump: float, p0: float, v0: float) -> SeriesRecord:
    """A cycle whose pressure still drifts on its plateaus; the meter misses the intake."""
    rate = 1.0
    seg = []
    for lo, hi in ((190.0, 190.0), (146.0, 147.0), (156.0, 157.5), (166.0, 166.8)):
        seg.append(np.linspace(lo, hi, 15) * BAR)
    p = np.concatenate(seg)
    q = np.full(p.size, q_pump * LPM)
    q[:15] = 0.0
    for k in range(1, 4):
        a, b = 15 * k, 15 * (k + 1)
        q[a:b] -= stored_rate(p[a:b], p0, v0, rate)
    t = np.arange(p.size, dtype=np.float64)
    return SeriesRecord(name, t, {"p_pump": p, "q_work": q,
                                  "oil_temperature": np.full(t.size, 40.0)},
                        {"p_pump": "Pa", "q_work": "m^3/s", "oil_temperature": "degC"})


def test_plateau_table_gives_the_intake_back() -> None:
    v0 = 0.6e-3
    recs = [_drifting("a", 7.9, 110 * BAR, v0), _drifting("b", 7.9, 150 * BAR, v0)]
    pre = np.array([110.0, 150.0]) * BAR
    plain = plateau_table(recs, plateaus=3)
    fixed = plateau_table(recs, plateaus=3, precharge=pre, gas_volume=v0)
    assert plain.intake is None and fixed.intake is not None
    # exact but for the ramp's curvature at the plateau's cut ends (one-sided there)
    assert fixed.flow == pytest.approx(np.full((2, 3), 7.9 * LPM), rel=1e-6)
    # the rising pressure takes oil in: the plain table reads low, by the intake
    assert np.all(plain.flow <= fixed.flow) and int(np.sum(plain.flow < fixed.flow)) == 5
    assert fixed.flow - plain.flow == pytest.approx(fixed.intake, rel=1e-9)
    # the 150 bar fill is empty on the 146-147 bar plateau: nothing taken in there
    assert fixed.intake[1, 0] == 0.0 and fixed.intake[0, 0] > 0.0
    with pytest.raises(InputError):
        plateau_table(recs, precharge=pre[:1], gas_volume=v0)
    with pytest.raises(InputError):
        plateau_table(recs, precharge=np.array([np.nan, 150 * BAR]), gas_volume=v0)


def test_leak_size_with_the_intake_orders_leakage_classes_on_the_slice() -> None:
    data, labels = load_1hz(zema_slice())
    recs = read_records(data)
    tau = 3.5
    pts = [cycle_point(r, stop_at_relief=True, relaxation=tau) for r in recs]

    def mu_of(th: np.ndarray) -> np.ndarray:
        return np.asarray(dynamic_viscosity(Fluid(), th), dtype=np.float64)

    pooled = shunt_estimates(recs, pts, mu_of(np.array([c.theta for c in pts])))
    fit = fit_precharge([step_volumes(r, relaxation=tau) for r in recs])
    theta = np.array([float(np.mean(r.channel("oil_temperature"))) for r in recs])
    pre = cycle_precharges(fit.p0, theta)
    tab = plateau_table(recs, relaxation=tau, precharge=pre, gas_volume=fit.v0)
    assert tab.intake is not None
    # the intake is a small correction: well under 1 % of the flow on every plateau
    assert float(np.max(np.abs(tab.intake / tab.flow))) < 0.01
    d = plateau_deficits(tab, ~pooled.leaking, pooled.slope)
    est = profile_sizes(d, tab.pressure, mu_of(tab.theta), tab.theta, pooled.leaking,
                        np.ones(len(recs), dtype=bool))
    med = [float(np.median(est.size[labels.leakage == c])) for c in (0, 1, 2)]
    assert abs(med[0]) < 0.1 * med[1] and med[1] < med[2]
    assert score_classes(est.size, labels.leakage, {}).worst_auroc == 1.0
