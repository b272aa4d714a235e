"""A step in a trend's level (diagnostics.level_shift) and the forecast after it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.level_shift import critical_f, level_shift
from diagnostics.trends import TrendSeries, forecast_threshold, theil_sen

DAY = 86400.0
SPAN = 266 * DAY


def _series(t: np.ndarray, y: np.ndarray, u: float) -> TrendSeries:
    return TrendSeries("r", "valve", "cv", "m", tuple(map(float, t)), tuple(map(float, y)),
                       (u,) * len(t))


def test_a_spool_that_stepped_and_stayed_is_a_step_not_wear() -> None:
    """The planner's case: cv 34 → 46 µm on one day, flat after; the straight line read
    "worsening, reaches 54.4 µm in 78 days" where the spool never gets there."""
    rng = np.random.default_rng(14)
    t = np.sort(rng.uniform(0, SPAN, 80))
    y = np.where(t >= 0.5 * SPAN, 46e-6, 34e-6) + rng.normal(0, 1e-6, t.size)
    forecast = forecast_threshold(_series(t, y, 1e-6), 34e-6 * 4.1 ** (1 / 3))
    assert forecast.step is not None
    assert forecast.step.time == pytest.approx(0.5 * SPAN, abs=5 * DAY)
    assert forecast.step.size == pytest.approx(12e-6, rel=0.1)
    assert forecast.n_used == int(np.sum(t > forecast.step.time))
    assert forecast.status == "not_worsening" and forecast.time_left == math.inf
    assert forecast.message.startswith("a step of +12")
    assert "µm in cv" in forecast.message
    without = forecast_threshold(_series(t, y, 1e-6), 34e-6 * 4.1 ** (1 / 3), steps=False)
    assert without.status == "worsening" and without.step is None


def test_steady_wear_a_flat_history_and_a_wrong_date_are_no_step() -> None:
    """1 % false alarms by construction; these seeds give none, nor does one reading
    entered with a date months early."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        t = np.sort(rng.uniform(0, SPAN, 40))
        for y in (83e-6 + 0.1767e-6 / DAY * t, np.full(t.size, 34e-6)):
            noisy = y + rng.normal(0, 2e-6, t.size)
            assert level_shift(t, noisy, theil_sen(t, noisy)[0], 2e-6) is None
    wrong = t.copy()
    wrong[-2] = 0.2 * SPAN
    y = 83e-6 + 0.1767e-6 / DAY * t + rng.normal(0, 2e-6, t.size)
    assert level_shift(wrong, y, theil_sen(wrong, y)[0], 2e-6) is None


def test_a_small_step_among_many_visits_is_below_the_practical_size() -> None:
    """400 visits make a step of one visit's σ significant; the estimates' own
    level-dependent biases are of that size, so a step must exceed twice a visit's
    uncertainty."""
    rng = np.random.default_rng(2)
    t = np.sort(rng.uniform(0, SPAN, 400))
    y = np.where(t >= 0.5 * SPAN, 36e-6, 34e-6) + rng.normal(0, 2e-6, t.size)
    slope = theil_sen(t, y)[0]
    assert level_shift(t, y, slope, 2e-6) is None
    # significant all the same: stated ten times tighter, the floor lets it through
    found = level_shift(t, y, slope, 0.2e-6)
    assert found is not None and found.size == pytest.approx(2e-6, abs=0.6e-6)


def test_the_critical_values_fall_with_the_number_of_visits() -> None:
    assert critical_f(10) == pytest.approx(22.2)
    assert critical_f(400) == pytest.approx(14.0) == critical_f(35_000)
    assert critical_f(10) > critical_f(25) > critical_f(100)
    assert level_shift(np.arange(9.0), np.arange(9.0), 1.0) is None   # too few visits


def test_a_step_resting_on_uncertain_visits_is_below_their_practical_size() -> None:
    """A healthy seal (cc 83 µm throughout): four visits at a light load and cold oil read
    low with u 14-19 µm, 22 at full load read 83 µm with u 2 µm.  The floor from every
    visit's median u (2 µm) let an 11.7 µm "step" through, smaller than one σ of the
    visits it rested on (a reliability engineer's pass); the less certain side sets it."""
    rng = np.random.default_rng(3)
    t = np.arange(26) * 7 * DAY
    y = np.concatenate([[75.8e-6, 70.7e-6, 68.6e-6, 74.3e-6],
                        83e-6 + rng.normal(0, 2e-6, 22)])
    u = np.array([16e-6, 17e-6, 19e-6, 14e-6] + [2e-6] * 22)
    slope = theil_sen(t, y)[0]
    assert level_shift(t, y, slope, float(np.median(u))) is not None   # as it was
    assert level_shift(t, y, slope, u) is None
    # the same readings stated as certain as the others are a step
    found = level_shift(t, y, slope, np.full(26, 2e-6))
    assert found is not None and found.size == pytest.approx(11e-6, abs=3e-6)
    series = TrendSeries("r", "cylinder", "cc", "m", tuple(map(float, t)),
                         tuple(map(float, y)), tuple(map(float, u)))
    assert forecast_threshold(series, 132.8e-6).step is None


def test_visits_after_a_repair_are_said_before_the_step_test_can_name_them() -> None:
    """A seal wearing 1.6 µm a week, replaced after 22 visits: the three visits of the new
    seal (83-86 µm) sat 35 µm below a line still forecasting the old seal's crossing,
    without a word (a reliability engineer's pass).  They are said; the fourth makes the
    step, and a healthy history's scatter says nothing."""
    rng = np.random.default_rng(0)
    t = np.arange(26) * 7 * DAY
    worn = 85e-6 + 1.6e-6 * np.arange(22) + rng.normal(0, 2e-6, 22)
    new = 83e-6 + 0.23e-6 * np.arange(4) + rng.normal(0, 2e-6, 4)
    y = np.concatenate([worn, new])

    def series(n: int, values: np.ndarray = y) -> TrendSeries:
        return TrendSeries("r", "cylinder", "cc", "m", tuple(map(float, t[:n])),
                           tuple(map(float, values[:n])), (2e-6,) * n)

    for visits in (1, 2, 3):
        after = forecast_threshold(series(22 + visits), 132.8e-6)
        assert after.step is None and after.status == "worsening"
        assert f"the latest {visits} visit(s), from " in after.message
        assert "below the fitted line (each beyond 3 σ)" in after.message, after.message
    four = forecast_threshold(series(26), 132.8e-6)
    assert four.step is not None and four.step.size < -25e-6
    assert "below the fitted line" not in four.message
    for seed in range(10):
        flat = 83e-6 + np.random.default_rng(seed).normal(0, 2e-6, 26)
        assert "fitted line (each" not in forecast_threshold(series(26, flat),
                                                             132.8e-6).message
