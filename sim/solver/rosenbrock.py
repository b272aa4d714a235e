"""Stiff integrator and steady-state solver for compiled bond graphs.

The functions take the right-hand side ``rhs(t, y, p, dy)`` as their first argument so
they can be read, tested and profiled as plain Python.  The code generator
(:mod:`sim.bondgraph.codegen`) copies their source into each generated model module with
that argument removed and compiles it with numba, so the right-hand side is called
directly (and the machine code is cached on disk).

Integrator: ROS2, the two-stage L-stable Rosenbrock method of Verwer et al. (1999),
``γ = 1 + 1/√2``::

    W = I − γ·h·J
    W·k1 = f(t, y) + γ·h·∂f/∂t
    W·k2 = f(t + h, y + h·k1) − 2·k1 − γ·h·∂f/∂t
    y⁺ = y + 3/2·h·k1 + 1/2·h·k2

(the ∂f/∂t terms follow from applying the autonomous method to the system augmented
with ``t' = 1``; they vanish for the rig's phases, whose sources are constant).

It is second order for *any* matrix J (a W-method), so a finite-difference Jacobian is
enough, and L-stability damps the stiff hydraulic modes (chamber compliance against the
orifices, β/V ≈ 1e13 Pa/m³) at any step size.  The embedded first-order solution
``y + h·k1`` gives the error estimate ``h/2·(k1 + k2)``.  Events: the integration stops
when a chosen state crosses a level, located by linear interpolation within the step.

References
----------
J.G. Verwer, E.J. Spee, J.G. Blom, W. Hundsdorfer, "A second-order Rosenbrock method
applied to photochemical dispersion problems", SIAM J. Sci. Comput. 20 (1999) 1456-1480.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

__all__ = ["integrate", "lu_factor", "lu_solve", "steady"]

Arr = npt.NDArray[np.float64]
IArr = npt.NDArray[np.int64]
RHS = Callable[[float, Arr, Arr, Arr], None]

STATUS_DONE = 0
STATUS_EVENT = 1
STATUS_CAPACITY = 2
STATUS_UNDERFLOW = 3


def lu_factor(a: Arr, piv: IArr) -> bool:
    """In-place LU factorisation with partial pivoting; False if singular."""
    n = a.shape[0]
    for k in range(n):
        m = k
        big = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                big = abs(a[i, k])
                m = i
        piv[k] = m
        if big == 0.0:
            return False
        if m != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[m, j]
                a[m, j] = tmp
        inv = 1.0 / a[k, k]
        for i in range(k + 1, n):
            a[i, k] *= inv
            lik = a[i, k]
            if lik != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= lik * a[k, j]
    return True


def lu_solve(a: Arr, piv: IArr, b: Arr) -> None:
    """Solve ``A x = b`` in place with the factors of :func:`lu_factor`."""
    n = a.shape[0]
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]


def fd_jacobian(rhs: RHS, t: float, y: Arr, p: Arr, f0: Arr, scale: Arr, jac: Arr,
                ywork: Arr, fwork: Arr) -> None:
    """Forward-difference Jacobian ``jac[i, j] = ∂f_i/∂y_j``."""
    n = y.size
    for j in range(n):
        ywork[j] = y[j]
    for j in range(n):
        d = 1.5e-8 * max(abs(y[j]), scale[j])
        ywork[j] = y[j] + d
        rhs(t, ywork, p, fwork)
        ywork[j] = y[j]
        for i in range(n):
            jac[i, j] = (fwork[i] - f0[i]) / d


def integrate(rhs: RHS, t0: float, t_end: float, y0: Arr, p: Arr, scale: Arr, rtol: float,
              h0: float, hmax: float, ev_state: int, ev_level: float, ev_dir: float,
              ts: Arr, ys: Arr) -> tuple[int, int, int]:
    """Integrate from ``t0`` to ``t_end`` or to an event, recording every accepted step.

    Parameters
    ----------
    rhs
        ``rhs(t, y, p, dy)`` writes dy/dt into ``dy``.
    t0, t_end
        Start and end time [s].
    y0
        Initial state.
    p
        Parameter vector.
    scale
        Typical magnitude of each state (absolute tolerance = ``rtol·scale``).
    rtol
        Relative tolerance of the local error.
    h0, hmax
        First and largest step [s].
    ev_state, ev_level, ev_dir
        Stop when ``y[ev_state] − ev_level`` changes sign in direction ``ev_dir``
        (+1 rising, −1 falling); ``ev_state < 0`` disables the event.
    ts, ys
        Output buffers (capacity = ``ts.size``): times and states of accepted steps.

    Returns
    -------
    (count, status, rejected)
        Number of recorded points, status (0 end reached, 1 event, 2 buffer full,
        3 step-size underflow) and the number of rejected steps.
    """
    n = y0.size
    cap = ts.size
    gamma = 1.0 + 1.0 / math.sqrt(2.0)
    y = y0.copy()
    yold = np.empty(n)
    ynew = np.empty(n)
    ytmp = np.empty(n)
    f0 = np.empty(n)
    f1 = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    jac = np.empty((n, n))
    w = np.empty((n, n))
    piv = np.zeros(n, dtype=np.int64)
    ywork = np.empty(n)
    fwork = np.empty(n)
    ft = np.zeros(n)
    t = t0
    h = h0
    rhs(t, y, p, f0)
    ts[0] = t
    for i in range(n):
        ys[0, i] = y[i]
    count = 1
    rejected = 0
    status = STATUS_DONE
    have_jac = False
    while t < t_end:
        h = min(h, hmax)
        if t + h > t_end:
            h = t_end - t
        if not have_jac:
            fd_jacobian(rhs, t, y, p, f0, scale, jac, ywork, fwork)
            dt = 1.5e-8 * max(abs(t), 1.0)
            rhs(t + dt, y, p, fwork)
            for i in range(n):
                ft[i] = (fwork[i] - f0[i]) / dt
            have_jac = True
        for i in range(n):
            for j in range(n):
                w[i, j] = -gamma * h * jac[i, j]
            w[i, i] += 1.0
        ok = lu_factor(w, piv)
        err = math.inf
        if ok:
            for i in range(n):
                k1[i] = f0[i] + gamma * h * ft[i]
            lu_solve(w, piv, k1)
            for i in range(n):
                ytmp[i] = y[i] + h * k1[i]
            rhs(t + h, ytmp, p, f1)
            for i in range(n):
                k2[i] = f1[i] - 2.0 * k1[i] - gamma * h * ft[i]
            lu_solve(w, piv, k2)
            acc = 0.0
            for i in range(n):
                ynew[i] = y[i] + 1.5 * h * k1[i] + 0.5 * h * k2[i]
                sc = rtol * (scale[i] + max(abs(y[i]), abs(ynew[i])))
                e = 0.5 * h * (k1[i] + k2[i]) / sc
                acc += e * e
            err = math.sqrt(acc / n)
        if err <= 1.0:
            for i in range(n):
                yold[i] = y[i]
                y[i] = ynew[i]
            told = t
            t = t + h
            rhs(t, y, p, f0)
            have_jac = False
            if ev_state >= 0:
                g0 = (yold[ev_state] - ev_level) * ev_dir
                g1 = (y[ev_state] - ev_level) * ev_dir
                if g0 < 0.0 <= g1:
                    theta = g0 / (g0 - g1)
                    t = told + theta * h
                    for i in range(n):
                        y[i] = yold[i] + theta * (y[i] - yold[i])
                    status = STATUS_EVENT
            if count >= cap:
                status = STATUS_CAPACITY
                break
            ts[count] = t
            for i in range(n):
                ys[count, i] = y[i]
            count += 1
            if status == STATUS_EVENT:
                break
            fac = 5.0 if err < 1e-4 else min(5.0, max(0.2, 0.9 / math.sqrt(err)))
            h = h * fac
        else:
            rejected += 1
            if math.isfinite(err):
                h = h * max(0.1, 0.9 / math.sqrt(err))
            else:
                h = h * 0.1
            if h < 1e-14 * max(1.0, abs(t)):
                status = STATUS_UNDERFLOW
                break
    return count, status, rejected


def steady(rhs: RHS, y0: Arr, p: Arr, mask: IArr, scale: Arr, tol: float, maxit: int,
           y: Arr) -> tuple[int, int, float]:
    """Damped Newton solution of ``f(y) = 0`` on the states where ``mask`` is 1.

    States with ``mask == 0`` (auxiliary integrals such as the piston position) are held
    at their value in ``y0``.  The Jacobian is by forward differences; steps are halved
    until the scaled residual norm decreases (Armijo).

    Returns
    -------
    (status, iterations, residual)
        status 0 converged, 1 not converged, 2 singular Jacobian; the scaled residual
        norm at exit.  The solution is written into ``y``.
    """
    n = y0.size
    idx = np.empty(n, dtype=np.int64)
    m = 0
    for i in range(n):
        y[i] = y0[i]
        if mask[i] != 0:
            idx[m] = i
            m += 1
    f = np.empty(n)
    ft = np.empty(n)
    yt = np.empty(n)
    jac = np.empty((m, m))
    piv = np.zeros(m, dtype=np.int64)
    dy = np.empty(m)
    rhs(0.0, y, p, f)
    res = 0.0
    for a in range(m):
        r = f[idx[a]] / scale[idx[a]]
        res += r * r
    res = math.sqrt(res)
    if not math.isfinite(res):
        # a NaN residual at the guess (a NaN parameter): no Newton step can be measured,
        # and a NaN step compared as converged there (a library user's pass)
        return 1, 0, res
    for it in range(maxit):
        for b in range(m):
            j = idx[b]
            d = 1.5e-8 * max(abs(y[j]), scale[j])
            for i in range(n):
                yt[i] = y[i]
            yt[j] = y[j] + d
            rhs(0.0, yt, p, ft)
            for a in range(m):
                jac[a, b] = (ft[idx[a]] - f[idx[a]]) / d
        for a in range(m):
            dy[a] = -f[idx[a]]
        if not lu_factor(jac, piv):
            return 2, it, res
        lu_solve(jac, piv, dy)
        lam = 1.0
        newres = math.inf
        decreased = False
        while lam > 1e-6:
            for i in range(n):
                yt[i] = y[i]
            for a in range(m):
                yt[idx[a]] = y[idx[a]] + lam * dy[a]
            rhs(0.0, yt, p, ft)
            newres = 0.0
            for a in range(m):
                r = ft[idx[a]] / scale[idx[a]]
                newres += r * r
            newres = math.sqrt(newres)
            if math.isfinite(newres) and newres <= (1.0 - 1e-4 * lam) * res:
                decreased = True
                break
            lam *= 0.5
        step = 0.0
        for a in range(m):
            i = idx[a]
            s = abs(lam * dy[a]) / (scale[i] + abs(y[i]))
            step = max(step, s)
        if not decreased:
            # no descent along the Newton direction: converged to round-off, or stuck
            return (0 if step < tol else 1), it + 1, res
        for i in range(n):
            y[i] = yt[i]
            f[i] = ft[i]
        res = newres
        if step < tol:
            return 0, it + 1, res
    return 1, maxit, res
