"""RODAS4 in plain Python (no compilation): order, dense output, events, buffers, limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from sim.solver.rodas import R4_DONE, R4_EVENT, R4_PAUSED, integrate_rodas

LAM = 1000.0


def stiff_linear(t, y, p, dy):
    # y0' = -λ (y0 - cos t) ; y1' = y0   (stiff, with a smooth slow solution)
    dy[0] = -p[0] * (y[0] - math.cos(t))
    dy[1] = y[0]


def exact_y1(t):
    # with y0(0) = λ²/(λ²+1) the fast transient is absent:  y1 = ∫ y0
    return (LAM**2 * np.sin(t) - LAM * np.cos(t) + LAM) / (LAM**2 + 1)


Y0 = np.array([LAM**2 / (LAM**2 + 1), 0.0])
P = np.array([LAM])


def run(rtol, *, t_end=2.0, grid=None, event=(-1, 0.0, 1.0), h0=1e-4, hmax=0.5,
        max_steps=10**6, y0=Y0):
    tol = np.full(2, rtol)
    g = np.empty(0) if grid is None else grid
    return integrate_rodas(stiff_linear, 0.0, t_end, y0.copy(), P, tol, rtol, h0, hmax,
                           event[0], event[1], event[2], g, max_steps)


def test_error_is_proportional_to_the_tolerance_and_steps_are_few():
    errs = []
    for rtol in (1e-4, 1e-5, 1e-6):
        _, _, _, status, y, t, _, counters = run(rtol)
        assert status == R4_DONE and t == 2.0
        errs.append(abs(y[1] - exact_y1(2.0)))
        assert counters[0] < 200  # an explicit method needs > 1000 steps for stability
    assert errs[2] < errs[1] < errs[0] < 1e-4


def test_fourth_order_at_fixed_steps():
    # a huge tolerance accepts every step at h = hmax: halving h divides the error by 2^4
    def err(h):
        out = integrate_rodas(stiff_linear, 0.0, 1.0, Y0.copy(), np.array([1.0]),
                              np.full(2, 1e6), 1e6, h, h, -1, 0.0, 1.0, np.empty(0), 10**6)
        t = 1.0  # λ = 1: y0 = (cos t + sin t)/2 + e^{-t}(y0(0) − 1/2)
        y0 = 0.5 * (math.cos(t) + math.sin(t)) + math.exp(-t) * (Y0[0] - 0.5)
        return abs(out[4][0] - y0)

    ratio = err(0.1) / err(0.05)
    assert 12.0 < ratio < 20.0


def test_dense_output_on_a_grid_matches_the_exact_solution():
    grid = np.linspace(0.0, 2.0, 2001)
    ts, ys, count, status, _, _, _, counters = run(1e-8, grid=grid)
    assert status == R4_DONE and count == grid.size
    assert counters[0] < count  # far fewer steps than samples: values come from the dense output
    assert np.max(np.abs(ys[:count, 1] - exact_y1(ts[:count]))) < 1e-8


def test_event_is_located_on_the_dense_output():
    ts, _ys, count, status, y, t, _, _ = run(1e-8, event=(1, 0.5, 1.0), hmax=0.5)
    assert status == R4_EVENT
    exact = brentq(lambda s: exact_y1(s) - 0.5, 0.1, 1.0)
    assert abs(t - exact) < 1e-8
    assert abs(y[1] - 0.5) < 1e-10
    assert ts[count - 1] == t


def test_step_buffers_grow_without_limit():
    _, _, count, status, _, _, _, counters = run(1e-6, t_end=30.0, hmax=0.01)
    assert status == R4_DONE
    assert count == counters[0] + 1 > 2 * 1024  # the first buffer holds 1024 rows


def test_step_limit_pauses_and_a_resumed_run_reaches_the_same_end():
    full = run(1e-7)
    first = run(1e-7, max_steps=20)
    assert first[3] == R4_PAUSED and first[5] < 2.0
    t, y, h = first[5], first[4], first[6]
    rest = integrate_rodas(stiff_linear, t, 2.0, y.copy(), P, np.full(2, 1e-7), 1e-7, h, 0.5,
                           -1, 0.0, 1.0, np.empty(0), 10**6)
    assert rest[3] == R4_DONE
    np.testing.assert_allclose(rest[4], full[4], rtol=0, atol=1e-9)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_non_finite_start_never_loops(bad):
    out = run(1e-6, y0=np.array([bad, 0.0]), max_steps=1000)
    assert out[3] != R4_DONE
