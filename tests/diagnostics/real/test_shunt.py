"""The orifice + laminar-shunt leak size: hand calculations, a synthetic round trip, a real slice."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.real.leakage import CyclePoint, cycle_point
from diagnostics.real.scoring import score_classes
from diagnostics.real.shunt import (
    fit_shunt,
    leak_threshold,
    plateau_slope,
    reference_flows,
    shunt_estimates,
)
from diagnostics.real.zema import load_1hz, read_records
from diagnostics.timeseries import SeriesRecord
from sim.components.gear_pump import dynamic_viscosity
from sim.errors import InputError
from sim.fluid import Fluid
from tests.real_slices import zema_slice

BAR = 1.0e5
LPM = 1.0 / 60000.0


def test_leak_threshold_splits_at_the_widest_gap() -> None:
    healthy = np.linspace(0.0, 0.05, 30) * LPM
    leaking = np.linspace(0.25, 0.40, 20) * LPM
    thr = leak_threshold(np.concatenate([leaking, healthy]))
    assert thr == pytest.approx(0.5 * (0.05 + 0.25) * LPM)
    with pytest.raises(InputError):
        leak_threshold(np.ones(5))


def test_plateau_slope_of_a_known_pump_line() -> None:
    t = np.arange(60, dtype=np.float64)
    levels = np.repeat([150.0, 160.0, 170.0, 160.0, 155.0, 150.0], 10) * BAR
    q = (8.0 - 0.01 * (levels / BAR - 150.0)) * LPM  # −0.01 l/min per bar
    rec = SeriesRecord("line", t, {"p_pump": levels, "q_work": q}, {"p_pump": "Pa",
                                                                      "q_work": "m^3/s"})
    assert plateau_slope(rec) == pytest.approx(-0.01 * LPM / BAR, rel=1e-9)


def test_reference_flow_moves_healthy_neighbours_to_the_cycles_pressure() -> None:
    pts = [CyclePoint("a", 150 * BAR, 8.0 * LPM, 40.0, 10),
           CyclePoint("b", 160 * BAR, 7.9 * LPM, 40.5, 10),
           CyclePoint("c", 155 * BAR, 7.5 * LPM, 40.2, 10)]
    healthy = np.array([True, True, False])
    slope = -0.01 * LPM / BAR
    ref = reference_flows(pts, healthy, slope)
    # both healthy cycles moved to 155 bar read 7.95 l/min: the median is 7.95
    assert ref[2] == pytest.approx(7.95 * LPM)
    assert ref[0] == pytest.approx(np.median([8.0, 7.9 + 0.1]) * LPM)


def test_the_shunt_comes_back_from_synthetic_cycles() -> None:
    rng = np.random.default_rng(7)
    n = 300
    theta = rng.uniform(35.0, 56.0, n)
    mu = dynamic_viscosity(Fluid(), theta)
    p = rng.uniform(148.0, 156.0, n) * BAR
    size = rng.choice([0.8e-9, 1.3e-9], n)  # two leak settings, independent of θ
    lam = 2.0e-15
    deficit = size * np.sqrt(p) + lam * p / mu
    found = fit_shunt(deficit, p, mu, theta, np.ones(n, dtype=bool), steps=2000)
    assert found == pytest.approx(lam, rel=0.02)
    # without a shunt in the data none is found
    assert fit_shunt(size * np.sqrt(p), p, mu, theta, np.ones(n, dtype=bool)) == 0.0
    with pytest.raises(InputError):
        fit_shunt(deficit[:5], p[:5], mu[:5], theta[:5], np.ones(5, dtype=bool))


def test_leak_size_orders_leakage_classes_on_the_slice() -> None:
    data, labels = load_1hz(zema_slice())
    recs = read_records(data)
    pts = [cycle_point(r) for r in recs]
    mu = dynamic_viscosity(Fluid(), np.array([c.theta for c in pts]))
    est = shunt_estimates(recs, pts, mu)
    assert np.array_equal(est.leaking, labels.leakage > 0)
    med = [float(np.median(est.size[labels.leakage == c])) for c in (0, 1, 2)]
    assert abs(med[0]) < 0.1 * med[1] and med[1] < med[2]
    s = score_classes(est.size, labels.leakage, {})
    assert s.worst_auroc == 1.0
    # the healthy pump line falls with pressure, a few thousandths of l/min per bar
    assert -0.02 * LPM / BAR < est.slope < 0.0
    assert est.shunt >= 0.0
    with pytest.raises(InputError):
        shunt_estimates(recs[:3], pts, mu)


def test_plateaus_after_a_relief_episode_are_left_out_on_request() -> None:
    # start-up at the relief valve (no flow), a working plateau, a relief episode in the
    # middle of the cycle (no flow), a last working plateau: the ZeMA cycles that left the
    # load program (e.g. cycle 502)
    t = np.arange(60, dtype=np.float64)
    p = np.repeat([190.0, 141.0, 188.0, 145.0], 15) * BAR
    q = np.repeat([0.0, 7.4, 1.1, 7.6], 15) * LPM
    rec = SeriesRecord("off-program", t, {"p_pump": p, "q_work": q,
                                          "oil_temperature": np.full(60, 56.0)},
                       {"p_pump": "Pa", "q_work": "m^3/s", "oil_temperature": "degC"})
    first = cycle_point(rec, stop_at_relief=True)
    both = cycle_point(rec)
    # the samples beside a jump are not steady (|dp/dt| from the central difference) and one
    # settle second is dropped: 12 samples of the first plateau, 13 of the last (no jump after)
    assert first.n == 12 and both.n == 25
    assert first.pressure == pytest.approx(141.0 * BAR) and first.flow == pytest.approx(7.4 * LPM)
    assert both.pressure == pytest.approx((12 * 141.0 + 13 * 145.0) / 25 * BAR)
    assert both.flow == pytest.approx((12 * 7.4 + 13 * 7.6) / 25 * LPM)
    # a cycle on its program (no relief episode after the first working plateau) is unchanged
    on = SeriesRecord("on-program", t, {"p_pump": np.repeat([190.0, 141.0, 151.0, 145.0], 15) * BAR,
                                        "q_work": np.repeat([0.0, 7.4, 7.3, 7.4], 15) * LPM,
                                        "oil_temperature": np.full(60, 50.0)},
                      {"p_pump": "Pa", "q_work": "m^3/s", "oil_temperature": "degC"})
    assert cycle_point(on, stop_at_relief=True) == cycle_point(on)
