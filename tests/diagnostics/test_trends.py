"""Trends: Theil–Sen slope with interval, time left to a threshold."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from diagnostics.trends import (
    DAY_S,
    EXACT_PAIRS,
    MIN_POINTS,
    TrendSeries,
    fit_trend,
    forecast_threshold,
    theil_sen,
)
from diagnostics.uncertainty import Estimate
from sim.errors import InputError

DAY = 86_400.0


def series(t_days, values, u=None, quantity="cc") -> TrendSeries:
    return TrendSeries("rig-1", "cylinder", quantity, "m", tuple(d * DAY for d in t_days),
                       tuple(values), None if u is None else tuple(u))


def test_exact_line_gives_exact_slope_and_time_left() -> None:
    # 83 µm growing 1 µm per 30 days; threshold 120 µm
    t = [0, 30, 60, 90, 120]
    s = series(t, [83e-6 + 1e-6 * d / 30 for d in t])
    fit = fit_trend(s)
    assert fit.slope == pytest.approx(1e-6 / (30 * DAY), rel=1e-12)
    assert fit.value_at(120 * DAY) == pytest.approx(87e-6, rel=1e-12)
    fc = forecast_threshold(s, 120e-6)
    assert fc.status == "worsening"
    assert fc.time_left == pytest.approx((120e-6 - 87e-6) / fit.slope, rel=1e-9)  # 990 days
    # no scatter and no stated u: the interval collapses onto the estimate
    assert fc.time_left_low == pytest.approx(fc.time_left, rel=1e-12)
    assert fc.time_left_high == pytest.approx(fc.time_left, rel=1e-12)


def test_slope_interval_covers_the_true_slope() -> None:
    rng = np.random.default_rng(11)
    true_slope = 2e-6 / (365 * DAY)
    hits, n = 0, 300
    for _ in range(n):
        t = np.sort(rng.uniform(0, 3 * 365, 10))
        y = 80e-6 + true_slope * t * DAY + rng.normal(0, 0.5e-6, t.size)
        fit = fit_trend(series(t, y))
        hits += fit.slope_low <= true_slope <= fit.slope_high
    assert 0.90 <= hits / n <= 0.99


def test_one_wrong_visit_barely_moves_the_robust_slope() -> None:
    t = np.arange(12.0) * 30
    y = 90e-6 + 0.05e-6 * t
    y_bad = y.copy()
    y_bad[6] += 40e-6  # a gross error in one visit
    robust = fit_trend(series(t, y_bad)).slope * DAY
    ols = np.polyfit(t, y_bad, 1)[0]
    assert robust == pytest.approx(0.05e-6, rel=0.05)
    assert abs(ols - 0.05e-6) > 5 * abs(robust - 0.05e-6)


def test_stated_uncertainties_widen_a_too_tidy_interval() -> None:
    t = [0, 100, 200]
    y = [80e-6, 81e-6, 82e-6]  # three points on a line: the rank interval has zero width
    u = [2e-6, 2e-6, 2e-6]
    fit = fit_trend(series(t, y, u))
    assert fit.rank_low == fit.rank_high == pytest.approx(fit.slope)
    tt = np.array(t) * DAY
    sigma_b = 1 / math.sqrt(np.sum((tt - tt.mean()) ** 2) / 2e-6**2)
    z = stats.norm.ppf(0.975)
    assert fit.slope_u_measurement == pytest.approx(sigma_b, rel=1e-12)
    assert fit.slope_low == pytest.approx(fit.slope - z * sigma_b, rel=1e-12)
    assert fit.slope_high == pytest.approx(fit.slope + z * sigma_b, rel=1e-12)
    fc = forecast_threshold(series(t, y, u), 100e-6)
    # the slope interval reaches zero: no worsening the data can show (the slope's sign
    # alone read "worsening" for healthy components, a planner's pass); the earliest
    # crossing the interval allows is still said
    assert fc.status == "not_worsening" and fc.time_left == fc.time_left_high == math.inf
    assert 0 < fc.time_left_low < math.inf
    assert "no significant worsening" in fc.message and "interval reaches zero" in fc.message


def test_improving_or_flat_series_is_not_worsening_and_raises_nothing() -> None:
    s = series([0, 30, 60, 90], [90e-6, 89e-6, 89.5e-6, 88e-6])
    fc = forecast_threshold(s, 120e-6)
    assert fc.status == "not_worsening"
    assert fc.time_left == math.inf and fc.time_left_high == math.inf
    assert fc.time_left_low > 0  # earliest crossing the steepest allowed slope would give
    flat = forecast_threshold(series([0, 30, 60], [90e-6] * 3), 120e-6)
    assert flat.status == "not_worsening" and flat.time_left_low == math.inf


def test_short_series_is_insufficient_not_an_error() -> None:
    fc = forecast_threshold(series([0, 30], [80e-6, 85e-6]), 120e-6)
    assert fc.status == "insufficient_data" and fc.fit is None
    assert math.isnan(fc.time_left)
    repeated = forecast_threshold(series([0, 0, 30, 30], [80e-6, 81e-6, 85e-6, 84e-6]),
                                  120e-6)
    assert repeated.status == "insufficient_data"  # two distinct visit times
    with pytest.raises(InputError):
        fit_trend(series([0, 30], [80e-6, 85e-6]))
    assert MIN_POINTS == 3


def test_already_crossed() -> None:
    """Past the threshold: time left 0, and when the fitted line crossed it (0.5 µm a day
    through (day 30, 115 µm): 120 µm on day 40, 20 days before the last visit)."""
    fc = forecast_threshold(series([0, 30, 60], [100e-6, 115e-6, 130e-6]), 120e-6)
    assert fc.status == "crossed" and fc.time_left == 0.0
    assert fc.crossed_at == pytest.approx(40.0 * DAY)
    assert "crossed it 20 days before" in fc.message
    level = forecast_threshold(series([0, 30, 60], [130e-6, 129e-6, 130e-6]), 120e-6)
    assert level.status == "crossed" and math.isnan(level.crossed_at)  # a level past it


def test_decreasing_direction_mirrors_increasing() -> None:
    t = [0, 40, 90, 150, 200]
    y = [0.97, 0.965, 0.962, 0.955, 0.951]  # volumetric efficiency falling
    down = forecast_threshold(series(t, y, quantity="eta_v"), 0.90, direction="decreasing")
    up = forecast_threshold(series(t, [-v for v in y], quantity="eta_v"), -0.90)
    assert down.status == up.status == "worsening"
    assert down.time_left == pytest.approx(up.time_left, rel=1e-12)
    assert down.time_left_low == pytest.approx(up.time_left_low, rel=1e-12)
    assert down.time_left_high == pytest.approx(up.time_left_high, rel=1e-12)
    assert down.fit is not None and down.fit.slope < 0  # reported in the original frame


def test_reference_time_moves_the_time_left() -> None:
    s = series([0, 30, 60, 90], [80e-6, 81e-6, 82e-6, 83e-6])
    later = forecast_threshold(s, 90e-6, now=120 * DAY)
    assert forecast_threshold(s, 90e-6).time_left - later.time_left == pytest.approx(30 * DAY)


def test_series_from_estimates_and_validation() -> None:
    est = [Estimate("cv", "m", v, 1e-6, v - 2e-6, v + 2e-6, "delta") for v in (34e-6, 36e-6,
                                                                                 39e-6)]
    s = TrendSeries.from_estimates("rig-1", "valve", [0.0, DAY, 2 * DAY], est)
    assert (s.quantity, s.unit, s.uncertainties) == ("cv", "m", (1e-6,) * 3)
    with pytest.raises(InputError) as err:
        series([0, 1, 2], [1.0, math.nan, 2.0])
    assert err.value.field == "values[1]"
    with pytest.raises(InputError) as err:
        series([0, 1], [1.0, 2.0, 3.0])
    assert err.value.field == "values"
    with pytest.raises(InputError):
        TrendSeries.from_estimates("rig-1", "valve", [0.0, 1.0], [
            est[0], Estimate("cc", "m", 1e-4, 1e-6, 0, 1, "delta")])


@pytest.mark.parametrize("case", ["random", "ties_in_t", "ties_in_y", "unsorted", "three",
                                  "one_outlier", "even_pairs", "long"])
def test_theil_sen_gives_scipys_numbers_exactly(case: str) -> None:
    """The partition-based Theil–Sen returns the very numbers of scipy's full-sort one."""
    rng = np.random.default_rng(sum(map(ord, case)))
    n = {"three": 3, "even_pairs": 5, "long": 1000}.get(case, 40)
    t = np.sort(rng.uniform(0.0, 1e7, n))
    y = 3e-12 * t + rng.normal(0.0, 1e-6, n)
    if case == "ties_in_t":
        t = np.round(t / 2e6) * 2e6  # visits on the same day
    if case == "ties_in_y":
        y = np.round(y * 1e5) / 1e5
    if case == "unsorted":
        p = rng.permutation(n)
        t, y = t[p], y[p]
    if case == "one_outlier":
        y[n // 2] += 1e-3
    for confidence in (0.95, 0.8):
        ref = stats.theilslopes(y, t, alpha=confidence, method="separate")
        got = theil_sen(t, y, confidence=confidence)
        assert got == (float(ref.slope), float(ref.low_slope), float(ref.high_slope))
        fit = fit_trend(TrendSeries("r", "valve", "cv", "m", tuple(t), tuple(y)),
                        confidence=confidence)
        assert (fit.slope, fit.rank_low, fit.rank_high) == got


def test_theil_sen_needs_two_distinct_times() -> None:
    with pytest.raises(InputError) as err:
        theil_sen([1.0, 1.0, 1.0], [0.0, 1.0, 2.0])
    assert err.value.field == "times"


def test_a_flat_trend_whose_steepest_slope_is_already_past_says_so() -> None:
    """Not worsening, but the slope interval's upper end puts the level past the threshold
    already: the message says so, not "would be reached in 0 s"."""
    from diagnostics.trends import TrendSeries, forecast_threshold

    day = 86400.0
    values = (40e-6, 70e-6, 40e-6, 70e-6, 40e-6)
    series = TrendSeries("r", "cylinder", "cc", "m", tuple(k * day for k in range(5)),
                         values, None)
    forecast = forecast_threshold(series, 60e-6)
    assert forecast.status == "not_worsening"
    assert forecast.time_left_low == 0.0
    assert "reached in 0 s" not in forecast.message
    assert "could already be past 60 µm" in forecast.message
    # both parts of the earliest crossing named: the steepest line's own crossing alone
    # was 11 times later than the time said (a reliability engineer's pass)
    assert "steepest slope the data allow, and the level at the top of its 95 % " \
        "interval" in forecast.message
    flat = forecast_threshold(TrendSeries("r", "cylinder", "cc", "m", series.times,
                                          (40e-6,) * 5, None), 60e-6)
    assert "not even the steepest slope the data allow reaches" in flat.message


def test_spans_read_in_the_trend_tables_unit() -> None:
    """Messages gave "1.83e+06 s" beside a table in days."""
    from diagnostics.trends import span

    assert span(20 * DAY) == "20 days"
    assert span(2 * 3600.0) == "2 h"
    assert span(42.0) == "42 s"
    assert span(math.inf) == "never"


def test_a_dimensionless_quantity_is_written_without_a_unit_of_1() -> None:
    """A pump's Cs [1] read "past 9.759e-08 1" and "slope … 1/s"."""
    cs = TrendSeries("rig-1", "pump", "Cs", "1", tuple(d * DAY for d in (0, 30, 60)),
                     (2e-8, 6e-8, 1.1e-7), None)
    past = forecast_threshold(cs, 9.759e-8)
    assert "past 9.759e-08 on the fitted trend" in past.message
    flat = forecast_threshold(TrendSeries("rig-1", "pump", "Cs", "1", cs.times,
                                          (3e-8, 2.9e-8, 2.8e-8), None), 9.759e-8)
    assert "per day)" in flat.message and " 1/" not in flat.message


def test_a_long_history_gives_the_exact_numbers_from_sampled_pairs() -> None:
    """Above EXACT_PAIRS points the slopes of random pairs stand for all of them (a rig with
    35,000 diagnoses took 21 GB for one trends request): the slope and its rank interval
    agree with scipy's exact ones to a small part of the interval's width."""
    rng = np.random.default_rng(11)
    n = EXACT_PAIRS + 500
    t = np.sort(rng.uniform(0.0, 365 * DAY_S, n))
    y = 80e-6 + 1e-13 * t + 2e-6 * rng.standard_normal(n)
    slope, low, high = theil_sen(t, y)
    exact = stats.theilslopes(y, t, alpha=0.95)
    width = exact.high_slope - exact.low_slope
    assert abs(slope - exact.slope) < 0.02 * width
    assert abs(low - exact.low_slope) < 0.05 * width
    assert abs(high - exact.high_slope) < 0.05 * width
    assert theil_sen(t, y) == (slope, low, high)  # the same series, the same numbers
    # a year of visits every few minutes: bounded, and still the line's slope
    big_t = np.linspace(0.0, 365 * DAY_S, 100_000)
    big = theil_sen(big_t, 80e-6 + 1e-13 * big_t + 2e-6 * rng.standard_normal(big_t.size))
    assert big[1] < 1e-13 < big[2] and abs(big[0] / 1e-13 - 1.0) < 0.05


def test_a_long_historys_slope_does_not_depend_on_the_order_of_its_points() -> None:
    """The sampled pairs index the time-sorted series, and points at one time (a visit's
    records, stored in whatever order) kept the order they came in: swapping each such
    pair moved the slope by 1.3 %.  Ties are now sorted by value."""
    rng = np.random.default_rng(3)
    t = np.repeat(np.arange(EXACT_PAIRS // 2 + 300, dtype=float), 2) * 3600.0
    y = 80e-6 + 1e-13 * t + 2e-6 * rng.standard_normal(t.size)
    swapped = np.arange(t.size).reshape(-1, 2)[:, ::-1].ravel()
    shuffled = rng.permutation(t.size)
    assert theil_sen(t[swapped], y[swapped]) == theil_sen(t, y)
    assert theil_sen(t[shuffled], y[shuffled]) == theil_sen(t, y)


def test_tied_values_say_the_slope_has_no_interval() -> None:
    """35,000 equal estimates 37 % below the threshold read "at the steepest slope the data
    allow it could already be past" it: the rank interval is undefined there."""
    times = tuple(float(k // 2) * 3600.0 for k in range(50))  # visits stored twice
    series = TrendSeries("rig-1", "cylinder", "cc", "m", times, (8.33e-5,) * 50)
    assert math.isnan(theil_sen(times, series.values)[1])  # ties in both: σ² < 0
    f = forecast_threshold(series, 1.328e-4)
    assert f.status == "not_worsening"
    assert "could already be past" not in f.message and "no interval" in f.message


def test_the_time_left_interval_holds_the_true_crossing_as_often_as_it_says() -> None:
    """Straight-line seal wear (83 → 130 µm over 266 days, 40 visits, ±2 µm): the lines
    through the median *value* held the true crossing in 8 of 12 campaigns (a planner's
    pass; 60-82 % in simulation); with the joint intercept and the level's uncertainty the
    95 % interval holds it in 94-96 % of simulated campaigns."""
    rng = np.random.default_rng(45)
    thr, rate = 132.84e-6, 0.1767e-6 / DAY
    held = 0
    for _ in range(200):
        t = np.sort(rng.uniform(0, 266 * DAY, 40))
        y = 83e-6 + rate * t + rng.normal(0, 2e-6, t.size)
        fc = forecast_threshold(series(t / DAY, y, [2e-6] * t.size), thr)
        truth = (thr - 83e-6) / rate - t[-1]
        held += fc.time_left_low <= truth <= fc.time_left_high
    assert 0.90 <= held / 200 <= 0.995


def test_one_record_with_a_wrong_date_hardly_moves_the_forecast() -> None:
    """A 129 µm reading typed with a date six months early moved the forecast from 13.6 to
    7.3 days through the median-value pivot (a planner's pass)."""
    rng = np.random.default_rng(4)
    t = np.sort(rng.uniform(0, 266, 40))
    y = 83e-6 + 0.1767e-6 * t + rng.normal(0, 2e-6, t.size)
    base = forecast_threshold(series(t, y, [2e-6] * t.size), 132.84e-6)
    t_bad, y_bad = np.append(t, 60.0), np.append(y, 129e-6)
    bad = forecast_threshold(series(t_bad, y_bad, [2e-6] * t_bad.size), 132.84e-6,
                             now=base.now)
    assert bad.step is None
    assert bad.time_left == pytest.approx(base.time_left, rel=0.15)


def test_a_flat_history_with_round_off_is_not_already_past() -> None:
    """A valve stored at 34 µm at every visit (round-off of 1e-20 m on some) read "it could
    already be past 54.42 µm": the quadrature divided the level's uncertainty by a slope of
    1e-25 (a check of the new-features)."""
    t = np.arange(20.0)
    values = 34e-6 + np.where(t % 3 == 0, 1e-20, 0.0)
    for sign in (1.0, -1.0):
        fc = forecast_threshold(series(t, 34e-6 + sign * (values - 34e-6), [1e-6] * 20),
                                54.42e-6)
        assert fc.status == "not_worsening"
        assert "already be past" not in fc.message
        assert fc.time_left_low > 60 * DAY


def test_a_slope_below_the_values_float_resolution_is_zero() -> None:
    """The same record diagnosed at each visit reads its last bit differently; the trend
    table showed a rate of "6e-15 µm/day" (a CLI pass). Such a slope is 0 exactly, while a
    real one a million times smaller than the wear rates of interest is kept."""
    t = np.arange(12.0)
    ulp = np.spacing(83e-6)
    noisy = 83e-6 + ulp * np.array([0, 1, 0, 2, 1, 3, 2, 4, 3, 5, 4, 6], dtype=float)
    fit = fit_trend(series(t, noisy))
    assert fit.slope == 0.0 and fit.slope_low <= 0.0 <= fit.slope_high
    real = 83e-6 + 1e-15 * t  # 1e-15 m/day: 1e-8 of the clearance over the span
    assert fit_trend(series(t, real)).slope * DAY == pytest.approx(1e-15, rel=1e-3, abs=0)
