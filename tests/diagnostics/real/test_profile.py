"""Leak size plateau by plateau: hand calculations, a synthetic round trip, a real slice."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.real.leakage import cycle_point
from diagnostics.real.profile import (
    PlateauTable,
    plateau_deficits,
    plateau_profile,
    plateau_table,
    profile_sizes,
)
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


def _record(name: str, levels: list[float], flows: list[float], theta: float) -> SeriesRecord:
    t = np.arange(15 * len(levels), dtype=np.float64)
    return SeriesRecord(name, t, {"p_pump": np.repeat(levels, 15) * BAR,
                                  "q_work": np.repeat(flows, 15) * LPM,
                                  "oil_temperature": np.full(t.size, theta)},
                        {"p_pump": "Pa", "q_work": "m^3/s", "oil_temperature": "degC"})


def test_plateau_table_numbers_the_working_plateaus_up_to_the_relief() -> None:
    on = _record("on", [190.0, 146.0, 156.0, 166.0], [0.0, 7.9, 7.8, 7.7], 40.0)
    # left the program: a relief episode after the first working plateau
    off = _record("off", [190.0, 141.0, 188.0, 145.0], [0.0, 7.4, 1.1, 7.6], 56.0)
    tab = plateau_table([on, off], plateaus=3)
    assert tab.pressure[0] == pytest.approx(np.array([146.0, 156.0, 166.0]) * BAR)
    assert tab.flow[0] == pytest.approx(np.array([7.9, 7.8, 7.7]) * LPM)
    assert tab.flow[1, 0] == pytest.approx(7.4 * LPM)
    assert np.all(np.isnan(tab.flow[1, 1:])) and np.all(np.isnan(tab.pressure[1, 1:]))
    assert list(tab.complete) == [True, False]
    assert tab.theta == pytest.approx([40.0, 56.0])
    with pytest.raises(InputError):
        plateau_table([on], plateaus=0)
    with pytest.raises(InputError):
        plateau_table([_record("dead", [190.0, 189.0], [0.0, 0.0], 40.0)])
    # a record without its oil temperature is named as such (it was a NaN that the bench
    # table refused as "theta: value is NaN (row 0)"); a stated condition stands in for it
    bare = _record("bare", [190.0, 146.0], [0.0, 7.9], 40.0)
    del bare.channels["oil_temperature"]
    with pytest.raises(InputError, match="'bare' has no channel 'oil_temperature'") as exc:
        plateau_table([bare])
    assert exc.value.field == "oil_temperature"
    bare.condition["oil_temperature"] = 47.0
    assert plateau_table([bare]).theta == pytest.approx([47.0])


def test_a_plateau_table_is_a_bench_table_row_by_plateau() -> None:
    on = _record("on", [190.0, 146.0, 156.0, 166.0], [0.0, 7.9, 7.8, 7.7], 40.0)
    off = _record("off", [190.0, 141.0, 188.0, 145.0], [0.0, 7.4, 1.1, 7.6], 56.0)
    tab = plateau_table([on, off], plateaus=3)
    b = tab.bench(157.0)
    assert b.q.size == 4 and not b.simulated
    assert b.p_out == pytest.approx(np.array([146.0, 156.0, 166.0, 141.0]) * BAR)
    assert b.q == pytest.approx(np.array([7.9, 7.8, 7.7, 7.4]) * LPM)
    assert b.theta == pytest.approx([40.0, 40.0, 40.0, 56.0])
    assert np.all(b.p_in == 0.0) and np.all(b.omega == 157.0)
    assert tab.bench(157.0, np.array([False, True])).q == pytest.approx([7.4 * LPM])
    for bad in (np.array([False, False]), np.array([True]), np.array([1, 0])):
        with pytest.raises(InputError) as exc:
            tab.bench(157.0, bad)
        assert exc.value.field == "cycles"


def test_deficit_is_taken_against_the_same_plateau_of_healthy_cycles() -> None:
    p = np.array([[146.0, 156.0], [147.0, 157.0], [146.0, 156.0], [141.0, np.nan]]) * BAR
    q = np.array([[7.90, 7.80], [7.88, 7.78], [7.60, 7.45], [7.50, np.nan]]) * LPM
    tab = PlateauTable(p, q, np.array([40.0, 40.4, 40.2, 40.3]))
    slope = -0.01 * LPM / BAR
    d = plateau_deficits(tab, np.array([True, True, False, False]), slope)
    # cycle 2, plateau 0: healthy 7.90 at 146 bar and 7.88 at 147 bar moved to 146 → 7.89
    assert d[2, 0] == pytest.approx((np.median([7.90, 7.89]) - 7.60) * LPM)
    assert d[2, 1] == pytest.approx((np.median([7.80, 7.79]) - 7.45) * LPM)
    # cycle 3 has its first plateau only, at 141 bar: healthy moved down by 5 and 6 bar
    assert d[3, 0] == pytest.approx((np.median([7.95, 7.94]) - 7.50) * LPM)
    assert np.isnan(d[3, 1])
    # out of the ±1 °C window: no reference
    far = PlateauTable(p, q, np.array([40.0, 40.4, 40.2, 45.0]))
    assert np.isnan(plateau_deficits(far, np.array([True, True, False, False]), slope)[3, 0])


def test_profile_puts_a_cycle_measured_on_its_first_plateau_on_the_whole_programs_scale() -> None:
    rng = np.random.default_rng(3)
    n = 400
    theta = rng.uniform(35.0, 57.0, n)
    mu = dynamic_viscosity(Fluid(), theta)
    size = rng.choice([0.0, 0.8e-9, 1.3e-9], n)
    leaking = size > 0
    levels = np.array([146.0, 156.0, 166.0, 156.0, 151.0]) * BAR
    p = np.tile(levels, (n, 1)) + rng.normal(0.0, 0.3 * BAR, (n, 5))
    profile = np.array([0.96, 0.99, 1.03, 1.01, 1.01])  # the leak grows through the cycle
    lam = 2.0e-15
    deficit = (size[:, None] * profile * np.sqrt(p)
               + lam * p / mu[:, None] * leaking[:, None])
    deficit += rng.normal(0.0, 0.002 * LPM, deficit.shape)
    short = rng.random(n) < 0.2  # cycles that left the program after two plateaus
    deficit[short, 2:] = np.nan
    p[short, 2:] = np.nan
    est = profile_sizes(deficit, p, mu, theta, leaking, ~short)
    assert est.shunt == pytest.approx(lam, rel=0.1)
    assert est.profile == pytest.approx(profile / profile.mean(), abs=0.01)
    for s in (0.8e-9, 1.3e-9):
        whole = est.size[(size == s) & ~short]
        first = est.size[(size == s) & short]
        # the same leak reads the same size whichever plateaus measured it …
        assert np.median(first) == pytest.approx(np.median(whole), rel=0.02)
        assert np.median(whole) == pytest.approx(s, rel=0.03)
        # … where the plain mean of the first two plateaus reads it low
        plain = np.nanmean(est.per_plateau[(size == s) & short], axis=1)
        assert np.median(plain) < 0.985 * np.median(whole)
    with pytest.raises(InputError):
        profile_sizes(deficit, p, mu, theta, np.zeros(n, dtype=bool), ~short)
    with pytest.raises(InputError):
        profile_sizes(deficit[:, :3], p, mu, theta, leaking, ~short)
    with pytest.raises(InputError):
        plateau_profile(deficit, np.zeros(n, dtype=bool))


def test_per_plateau_leak_size_orders_leakage_classes_on_the_slice() -> None:
    data, labels = load_1hz(zema_slice())
    recs = read_records(data)
    tau = 3.5
    pts = [cycle_point(r, stop_at_relief=True, relaxation=tau) for r in recs]

    def mu_of(th: np.ndarray) -> np.ndarray:
        return np.asarray(dynamic_viscosity(Fluid(), th), dtype=np.float64)

    pooled = shunt_estimates(recs, pts, mu_of(np.array([c.theta for c in pts])))
    tab = plateau_table(recs, relaxation=tau)
    assert bool(np.all(tab.complete))  # the slice's cycles all ran the whole program
    d = plateau_deficits(tab, ~pooled.leaking, pooled.slope)
    est = profile_sizes(d, tab.pressure, mu_of(tab.theta), tab.theta, pooled.leaking,
                        np.ones(len(recs), dtype=bool))
    med = [float(np.median(est.size[labels.leakage == c])) for c in (0, 1, 2)]
    assert abs(med[0]) < 0.1 * med[1] and med[1] < med[2]
    assert score_classes(est.size, labels.leakage, {}).worst_auroc == 1.0
    assert est.shunt >= 0.0 and float(np.mean(est.profile)) == pytest.approx(1.0, abs=0.02)
