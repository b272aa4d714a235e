"""How a phase is read (sim.phase_reading): windows and averages against hand calculations."""

from __future__ import annotations

import numpy as np
import pytest

from sim.phase_reading import (
    SETTLED_SHARE,
    settled_window,
    steady_slope,
    steady_window,
    time_average,
)


def test_a_steady_stroke_is_read_between_10_and_90_percent_of_its_travel() -> None:
    t = np.linspace(0.0, 2.0, 201)
    x = 0.25 * t                                   # 0.5 m at 0.25 m/s
    sel = steady_window(x)
    assert x[sel].min() == pytest.approx(0.05) and x[sel].max() == pytest.approx(0.45)
    assert steady_slope(t[sel], x[sel]) == pytest.approx(0.25, rel=1e-12)
    # a retracting stroke reads the same magnitude
    assert steady_slope(t[sel], 0.5 - x[sel]) == pytest.approx(0.25, rel=1e-12)


def test_a_piston_that_barely_moved_is_read_whole() -> None:
    assert steady_window(np.zeros(5)).all()
    assert steady_window(np.array([0.0, 0.0, 1e-3])).all()   # fewer than 3 in the middle


def test_time_averages_weigh_each_sample_by_its_time() -> None:
    t = np.array([0.0, 1.0, 3.0])
    p = np.array([1.0, 2.0, 4.0])                  # linear in t: the mean is its midpoint
    assert time_average(p, t) == pytest.approx(2.5)
    assert time_average(np.array([7.0]), np.array([1.0])) == 7.0


def test_a_stalled_phase_is_read_over_its_last_half() -> None:
    t = np.linspace(0.0, 10.0, 11)
    sel = settled_window(t)
    assert t[sel][0] == pytest.approx(10.0 * (1.0 - SETTLED_SHARE)) and t[sel][-1] == 10.0
    assert settled_window(np.array([0.0, 1.0])).all()
    assert steady_slope(np.array([1.0]), np.array([0.0])) == 0.0
