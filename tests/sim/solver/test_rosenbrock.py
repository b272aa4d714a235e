"""ROS2 integrator and Newton steady-state solver, in plain Python (no compilation)."""

from __future__ import annotations

import math

import numpy as np

from sim.solver.rosenbrock import integrate, lu_factor, lu_solve, steady


def stiff_linear(t, y, p, dy):
    # y0' = -1000 (y0 - cos t) ; y1' = y0   (stiff, with a smooth slow solution)
    dy[0] = -p[0] * (y[0] - math.cos(t))
    dy[1] = y[0]


def test_lu_solves_a_random_system():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(6, 6))
    b = rng.normal(size=6)
    lu = a.copy()
    piv = np.zeros(6, dtype=np.int64)
    assert lu_factor(lu, piv)
    x = b.copy()
    lu_solve(lu, piv, x)
    assert np.allclose(a @ x, b)


def _run(rtol):
    ts, ys = np.empty(20000), np.empty((20000, 2))
    n, status, _ = integrate(stiff_linear, 0.0, 2.0, np.array([1.0, 0.0]), np.array([1000.0]),
                             np.array([1.0, 1.0]), rtol, 1e-6, 0.1, -1, 0.0, 1.0, ts, ys)
    assert status == 0
    return n, ys[n - 1]


def test_stiff_linear_problem_is_accurate_with_few_steps():
    # exact slow solution y0 ≈ (cos t + 1e-3 sin t)/(1 + 1e-6), y1 = ∫ y0
    n, y = _run(1e-5)
    lam = 1000.0
    y0 = (lam**2 * math.cos(2.0) + lam * math.sin(2.0)) / (lam**2 + 1)
    y1 = (lam**2 * math.sin(2.0) - lam * math.cos(2.0) + lam) / (lam**2 + 1)
    assert abs(y[0] - y0) < 1e-4 and abs(y[1] - y1) < 1e-4
    assert n < 2000  # an explicit method would need > 2000 steps for stability alone


def test_error_falls_with_tolerance():
    lam = 1000.0
    y1 = (lam**2 * math.sin(2.0) - lam * math.cos(2.0) + lam) / (lam**2 + 1)
    errs = [abs(_run(r)[1][1] - y1) for r in (1e-3, 1e-4, 1e-5)]
    assert errs[0] > errs[1] > errs[2]


def test_event_stops_at_the_crossing():
    def ramp(t, y, p, dy):
        dy[0] = 2.0

    ts, ys = np.empty(1000), np.empty((1000, 1))
    n, status, _ = integrate(ramp, 0.0, 10.0, np.array([0.0]), np.zeros(1), np.ones(1), 1e-6,
                             1e-3, 0.3, 0, 1.0, 1.0, ts, ys)
    assert status == 1
    assert ts[n - 1] == np.float64(0.5) or abs(ts[n - 1] - 0.5) < 1e-12
    assert abs(ys[n - 1, 0] - 1.0) < 1e-12


def test_newton_finds_the_steady_state_and_holds_frozen_states():
    def f(t, y, p, dy):
        dy[0] = 4.0 - y[0] ** 2  # root 2
        dy[1] = y[0] - 2.0 * y[1]  # root y0/2
        dy[2] = 1.0  # frozen: never zero

    y = np.empty(3)
    status, its, _ = steady(f, np.array([1.0, 0.0, 7.0]), np.zeros(1),
                            np.array([1, 1, 0], dtype=np.int64), np.ones(3), 1e-12, 50, y)
    assert status == 0 and its < 20
    assert np.allclose(y, [2.0, 1.0, 7.0])


def test_newton_does_not_call_a_nan_residual_converged():
    """A NaN parameter made every step NaN; ``max(0, nan)`` kept 0, and the guess was
    returned as converged — the last operating point solved (a library user's pass)."""
    def f(t, y, p, dy):
        dy[0] = p[0] * (4.0 - y[0] ** 2)

    y = np.empty(1)
    status, its, res = steady(f, np.array([1.0]), np.array([np.nan]),
                              np.array([1], dtype=np.int64), np.ones(1), 1e-12, 50, y)
    assert status == 1 and its == 0 and math.isnan(res)
    status, _, _ = steady(f, np.array([1.0]), np.array([1.0]),
                          np.array([1], dtype=np.int64), np.ones(1), 1e-12, 50, y)
    assert status == 0 and abs(y[0] - 2.0) < 1e-12
