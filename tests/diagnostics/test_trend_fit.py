"""The robust straight line of a parameter's history (:mod:`diagnostics.trend_fit`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.trend_fit import TrendSeries, fit_trend

DAY = 86_400.0


def _series(t: np.ndarray, y: np.ndarray, u: float | None = None) -> TrendSeries:
    return TrendSeries("rig-1", "cylinder", "cc", "m", tuple(float(x) for x in t),
                       tuple(float(x) for x in y), None if u is None else (u,) * len(t))


def test_stated_uncertainties_widen_a_collinear_series_by_the_wls_slope_error() -> None:
    # five visits a day apart on an exact line (the rank interval collapses to the slope):
    # the interval is then the weighted least-squares slope's ±z·σ_b with, for equal u,
    # σ_b = u/√Σ(tᵢ − t̄)² = 1e-7/√(10·DAY²) [m/s] and z = 1.959964 at 95 %; the level's
    # standard uncertainty is that of a median of 5 readings of σ = u:
    # √(π/2)·u/√5 = 1.2533·1e-7/2.2361 = 5.605e-8 m
    t = 1.7e9 + DAY * np.arange(5.0)  # Unix times: the answer must not depend on the origin
    slope = 2e-6 / (30 * DAY)  # 2 µm a month
    fit = fit_trend(_series(t, 80e-6 + slope * (t - t[0]), u=1e-7))
    sigma_b = 1e-7 / math.sqrt(10.0 * DAY**2)
    assert fit.slope == pytest.approx(slope, rel=1e-6, abs=0)
    assert fit.slope_u_measurement == pytest.approx(sigma_b, rel=1e-9, abs=0)
    assert fit.slope_low == pytest.approx(slope - 1.959964 * sigma_b, rel=1e-6, abs=0)
    assert fit.slope_high == pytest.approx(slope + 1.959964 * sigma_b, rel=1e-6, abs=0)
    assert fit.level_u == pytest.approx(5.605e-8, rel=1e-3, abs=0)
    assert fit.pivot_time == t[2]
    assert fit.pivot_value == pytest.approx(80e-6 + 2 * DAY * slope, rel=1e-12, abs=0)


def test_each_interval_line_halves_the_points() -> None:
    # the level of each line is its joint (Conover) intercept: at the median time, half
    # the points lie above the line of slope slope_low through level_low, half below, and
    # the same for slope_high and level_high (odd n, no ties)
    rng = np.random.default_rng(5)
    t = DAY * np.sort(rng.uniform(0.0, 300.0, 21))
    y = 80e-6 + 1e-8 * (t / DAY) + rng.normal(0.0, 3e-7, t.size)
    fit = fit_trend(_series(t, y))
    assert fit.slope_low < fit.slope < fit.slope_high
    for slope, level in ((fit.slope_low, fit.level_low), (fit.slope_high, fit.level_high),
                         (fit.slope, fit.pivot_value)):
        r = y - (level + slope * (t - fit.pivot_time))
        assert np.sum(r > 0) == np.sum(r < 0) == 10


def test_a_tiny_but_real_drift_is_kept() -> None:
    # a ratio near 1 drifting 1e-7 over ten years (3e-16 per second): its change over the
    # span is ~450 times the float resolution of the values (64 ulps of 1), so it is a
    # slope, not rounding; a slope compared with the resolution without the span
    # (a mutation review) read it as 0
    t = np.linspace(0.0, 3.15e8, 11)
    fit = fit_trend(_series(t, 1.0 + 3e-16 * t))
    assert fit.slope == pytest.approx(3e-16, rel=1e-4, abs=0)
    # and a series that differs only in its last bits has no slope
    flat = fit_trend(_series(t, 1.0 + np.array([0, 1, 0, 2, 1, 0, 1, 2, 0, 1, 0]) * 2.2e-16))
    assert flat.slope == 0.0
