"""RODAS4: a fourth-order stiffly accurate Rosenbrock method with dense output.

Like :mod:`sim.solver.rosenbrock`, the functions take the right-hand side
``rhs(t, y, p, dy)`` as their first argument so they run as plain Python in tests; the
code generator copies them into each generated model module with that argument removed
and numba compiles them there (no Python in the step loop).

Method (Hairer & Wanner 1996, §IV.7: the coefficient set of their code ``RODAS``,
six stages, γ = 1/4, stiffly accurate, L-stable)::

    (I/(γh) − J)·k_i = f(t + α_i h, y + Σ_j a_ij k_j) + Σ_j (c_ij/h)·k_j + γ_i h ∂f/∂t
    y⁺ = y + Σ_j a_6j k_j + k_6             (order 4; stage 5 gives the order-3 solution)

The difference of the two, ``k_6``, is the local error estimate.  Dense output on
``θ ∈ [0, 1]`` (Hairer & Wanner's ``CONTRO``)::

    y(t + θh) = (1 − θ)·y + θ·(y⁺ + (1 − θ)·(d₂·k + θ·d₃·k))

Per-state tolerances: a component's error counts against ``atol_i + rtol·max(|y_i|,
|y⁺_i|)``; the caller sets ``atol_i`` from each state's scale.  Step-size control is the
standard ``h·clip(0.9·err^(−1/4), 1/6, 5)`` with Gustafsson's predictive correction
after accepted steps.  Events: after each accepted step the event function
``s·(y_k − level)`` is checked for a sign change and the crossing is located on the dense
output by the Illinois (modified regula falsi) method to 1e-12 of the step.

Output: either every accepted step or the points of a sampling grid within the run,
evaluated from the dense output; the buffers start at 1024 rows and double when full (no
fixed limit, and memory in proportion to what is written, not to the grid's length).
Work is bounded by ``max_steps`` accepted + rejected steps per call; the call returns
with status :data:`STATUS_PAUSED` and its step size so a caller can check a wall-clock
budget and go on.

References
----------
E. Hairer, G. Wanner, *Solving Ordinary Differential Equations II: Stiff and
Differential-Algebraic Problems*, 2nd ed., Springer (1996), §IV.7 (Rosenbrock methods,
RODAS coefficient set, dense output).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from sim.solver.rosenbrock import fd_jacobian, lu_factor, lu_solve

__all__ = ["dense_eval", "grow_rows", "integrate_rodas"]

Arr = npt.NDArray[np.float64]
IArr = npt.NDArray[np.int64]
RHS = Callable[[float, Arr, Arr, Arr], None]

R4_DONE = 0
R4_EVENT = 1
R4_UNDERFLOW = 3
R4_PAUSED = 4
R4_NONFINITE = 5

#: exported with the ROS2 statuses' names for the model layer
STATUS_PAUSED = R4_PAUSED
STATUS_NONFINITE = R4_NONFINITE


def grow_rows(ts: Arr, ys: Arr, count: int) -> tuple[Arr, Arr]:
    """Output buffers of twice the rows, holding the first ``count`` rows of ``ts``/``ys``."""
    cap = 2 * ts.shape[0]
    ts2 = np.empty(cap)
    ys2 = np.empty((cap, ys.shape[1]))
    ts2[:count] = ts[:count]
    ys2[:count] = ys[:count]
    return ts2, ys2


def dense_eval(theta: float, y: Arr, ynew: Arr, q1: Arr, q2: Arr, out: Arr) -> None:
    """Dense output at ``t + θ·h``: ``(1−θ)·y + θ·(y⁺ + (1−θ)·(q1 + θ·q2))``."""
    s1 = 1.0 - theta
    for i in range(y.size):
        out[i] = s1 * y[i] + theta * (ynew[i] + s1 * (q1[i] + theta * q2[i]))


def integrate_rodas(rhs: RHS, t0: float, t_end: float, y0: Arr, p: Arr, atol: Arr,
                    rtol: float, h0: float, hmax: float, ev_state: int, ev_level: float,
                    ev_dir: float, grid: Arr, max_steps: int,
                    ) -> tuple[Arr, Arr, int, int, Arr, float, float, IArr]:
    """Integrate from ``t0`` to ``t_end`` or to an event with RODAS4.

    Parameters
    ----------
    rhs
        ``rhs(t, y, p, dy)`` writes dy/dt into ``dy``.
    t0, t_end
        Start and end time [s].
    y0, p
        Initial state and parameter vector.
    atol
        Absolute tolerance of each state [state unit].
    rtol
        Relative tolerance [-].
    h0, hmax
        First and largest step [s].
    ev_state, ev_level, ev_dir
        Stop when ``y[ev_state] − ev_level`` changes sign in direction ``ev_dir``
        (+1 rising, −1 falling); ``ev_state < 0`` disables the event.
    grid
        Sampling times [s], increasing; empty: record ``t0`` and every accepted step.
        Grid points outside ``[t0, t_reached]`` are not written.
    max_steps
        Most steps (accepted + rejected) of this call; then status 4 (paused).

    Returns
    -------
    (ts, ys, count, status, y_reached, t_reached, h_next, counters)
        Recorded times and states (first ``count`` rows), status (0 end reached, 1 event,
        3 step-size underflow, 4 paused at the step limit, 5 non-finite state), the
        state and time reached, the next step size [s] and the counters ``[accepted,
        rejected, right-hand-side evaluations]``.
    """
    n = y0.size
    gam = 0.25
    c2, c3, c4 = 0.386, 0.21, 0.63
    d1, d2, d3, d4 = 0.25, -0.1043, 0.1035, -0.3620000000000023e-01
    a21 = 0.1544e+01
    a31, a32 = 0.9466785280815826, 0.2557011698983284
    a41, a42, a43 = 0.3314825187068521e+01, 0.2896124015972201e+01, 0.9986419139977817
    a51, a52 = 0.1221224509226641e+01, 0.6019134481288629e+01
    a53, a54 = 0.1253708332932087e+02, -0.6878860361058950
    c21 = -0.56688e+01
    c31, c32 = -0.2430093356833875e+01, -0.2063599157091915
    c41, c42, c43 = -0.1073529058151375, -0.9594562251023355e+01, -0.2047028614809616e+02
    c51, c52 = 0.7496443313967647e+01, -0.1024680431464352e+02
    c53, c54 = -0.3399990352819905e+02, 0.1170890893206160e+02
    c61, c62 = 0.8083246795921522e+01, -0.7981132988064893e+01
    c63, c64, c65 = -0.3152159432874371e+02, 0.1631930543123136e+02, -0.6058818238834054e+01
    e21, e22, e23 = 0.1012623508344586e+02, -0.7487995877610167e+01, -0.3480091861555747e+02
    e24, e25 = -0.7992771707568823e+01, 0.1025137723295662e+01
    e31, e32, e33 = -0.6762803392801253, 0.6087714651680015e+01, 0.1643084320892478e+02
    e34, e35 = 0.2476722511418386e+02, -0.6594389125716872e+01

    gridded = grid.size > 0
    cap = 1024
    ts = np.empty(cap)
    ys = np.empty((cap, n))
    count = 0
    gi = 0
    if gridded:
        while gi < grid.size and grid[gi] < t0:
            gi += 1
    y = y0.copy()
    ynew = np.empty(n)
    yst = np.empty(n)
    f0 = np.empty(n)
    fs = np.empty(n)
    ft = np.zeros(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    k5 = np.empty(n)
    k6 = np.empty(n)
    q1 = np.empty(n)
    q2 = np.empty(n)
    yd = np.empty(n)
    jac = np.empty((n, n))
    w = np.empty((n, n))
    piv = np.zeros(n, dtype=np.int64)
    ywork = np.empty(n)
    fwork = np.empty(n)
    counters = np.zeros(3, dtype=np.int64)
    t = t0
    h = min(h0, hmax)
    rhs(t, y, p, f0)
    counters[2] += 1
    if gridded:
        while gi < grid.size and grid[gi] <= t0:
            if count >= ts.shape[0]:
                ts, ys = grow_rows(ts, ys, count)
            ts[count] = grid[gi]
            for i in range(n):
                ys[count, i] = y[i]
            count += 1
            gi += 1
    else:
        ts[0] = t
        for i in range(n):
            ys[0, i] = y[i]
        count = 1
    status = R4_DONE
    have_jac = False
    first = True
    reject = False
    hold = h
    errold = 1.0
    steps = 0
    while t < t_end:
        if steps >= max_steps:
            status = R4_PAUSED
            break
        steps += 1
        h = min(h, hmax)
        if t + h > t_end:
            h = t_end - t
        if h < 1e-14 * max(1.0, abs(t)):
            status = R4_UNDERFLOW
            break
        if not have_jac:
            fd_jacobian(rhs, t, y, p, f0, atol, jac, ywork, fwork)
            dt = 1.5e-8 * max(abs(t), 1.0)
            rhs(t + dt, y, p, fwork)
            for i in range(n):
                ft[i] = (fwork[i] - f0[i]) / dt
            counters[2] += n + 1
            have_jac = True
        fac0 = 1.0 / (gam * h)
        for i in range(n):
            for j in range(n):
                w[i, j] = -jac[i, j]
            w[i, i] += fac0
        err = math.inf
        if lu_factor(w, piv):
            for i in range(n):
                k1[i] = f0[i] + h * d1 * ft[i]
            lu_solve(w, piv, k1)
            for i in range(n):
                yst[i] = y[i] + a21 * k1[i]
            rhs(t + c2 * h, yst, p, fs)
            for i in range(n):
                k2[i] = fs[i] + h * d2 * ft[i] + c21 * k1[i] / h
            lu_solve(w, piv, k2)
            for i in range(n):
                yst[i] = y[i] + a31 * k1[i] + a32 * k2[i]
            rhs(t + c3 * h, yst, p, fs)
            for i in range(n):
                k3[i] = fs[i] + h * d3 * ft[i] + (c31 * k1[i] + c32 * k2[i]) / h
            lu_solve(w, piv, k3)
            for i in range(n):
                yst[i] = y[i] + a41 * k1[i] + a42 * k2[i] + a43 * k3[i]
            rhs(t + c4 * h, yst, p, fs)
            for i in range(n):
                k4[i] = fs[i] + h * d4 * ft[i] + (c41 * k1[i] + c42 * k2[i] + c43 * k3[i]) / h
            lu_solve(w, piv, k4)
            for i in range(n):
                yst[i] = y[i] + a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i]
            rhs(t + h, yst, p, fs)
            for i in range(n):
                k5[i] = fs[i] + (c51 * k1[i] + c52 * k2[i] + c53 * k3[i] + c54 * k4[i]) / h
            lu_solve(w, piv, k5)
            for i in range(n):
                yst[i] += k5[i]
            rhs(t + h, yst, p, fs)
            for i in range(n):
                k6[i] = fs[i] + (c61 * k1[i] + c62 * k2[i] + c63 * k3[i] + c64 * k4[i]
                                 + c65 * k5[i]) / h
            lu_solve(w, piv, k6)
            counters[2] += 5
            acc = 0.0
            for i in range(n):
                ynew[i] = yst[i] + k6[i]
                sk = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
                e = k6[i] / sk
                acc += e * e
            err = math.sqrt(acc / n)
        if not math.isfinite(err):
            counters[1] += 1
            reject = True
            h *= 0.1
            continue
        fac = max(1.0 / 6.0, min(5.0, err ** 0.25 / 0.9))
        hnew = h / fac
        if err <= 1.0:
            if not first:
                facp = (hold / h) * (err * err / errold) ** 0.25 / 0.9
                facp = max(1.0 / 6.0, min(5.0, facp))
                hnew = h / max(fac, facp)
            first = False
            hold = h
            errold = max(0.01, err)
            if reject:
                hnew = min(hnew, h)
            reject = False
            counters[0] += 1
            for i in range(n):
                q1[i] = e21 * k1[i] + e22 * k2[i] + e23 * k3[i] + e24 * k4[i] + e25 * k5[i]
                q2[i] = e31 * k1[i] + e32 * k2[i] + e33 * k3[i] + e34 * k4[i] + e35 * k5[i]
            theta_end = 1.0
            if ev_state >= 0:
                g0 = (y[ev_state] - ev_level) * ev_dir
                g1 = (ynew[ev_state] - ev_level) * ev_dir
                if g0 < 0.0 <= g1:
                    lo, hi, glo, ghi = 0.0, 1.0, g0, g1
                    side = 0
                    th = 1.0
                    for _ in range(100):
                        th = (lo * ghi - hi * glo) / (ghi - glo)
                        dense_eval(th, y, ynew, q1, q2, yd)
                        g = (yd[ev_state] - ev_level) * ev_dir
                        if g >= 0.0:
                            hi, ghi = th, g
                            if side == 1:
                                glo *= 0.5
                            side = 1
                        else:
                            lo, glo = th, g
                            if side == -1:
                                ghi *= 0.5
                            side = -1
                        if hi - lo < 1e-12 or g == 0.0:
                            break
                    theta_end = hi
                    status = R4_EVENT
            t_stop = t + theta_end * h
            if gridded:
                while gi < grid.size and grid[gi] <= t_stop:
                    if count >= ts.shape[0]:
                        ts, ys = grow_rows(ts, ys, count)
                    dense_eval((grid[gi] - t) / h, y, ynew, q1, q2, yd)
                    ts[count] = grid[gi]
                    for i in range(n):
                        ys[count, i] = yd[i]
                    count += 1
                    gi += 1
            if status == R4_EVENT:
                dense_eval(theta_end, y, ynew, q1, q2, yd)
                for i in range(n):
                    ynew[i] = yd[i]
            t = t_stop if status == R4_EVENT else t + h
            for i in range(n):
                y[i] = ynew[i]
            if not gridded:
                if count >= ts.shape[0]:
                    ts, ys = grow_rows(ts, ys, count)
                ts[count] = t
                for i in range(n):
                    ys[count, i] = y[i]
                count += 1
            finite = True
            for i in range(n):
                if not math.isfinite(y[i]):
                    finite = False
            if not finite:
                status = R4_NONFINITE
                break
            if status == R4_EVENT:
                break
            rhs(t, y, p, f0)
            counters[2] += 1
            have_jac = False
            h = hnew
        else:
            counters[1] += 1
            reject = True
            h = hnew
    return ts, ys, count, status, y, t, h, counters
