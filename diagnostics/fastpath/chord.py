"""Chord Newton for the signature maps' grid solves (source compiled into the rig's
generated numba module, :mod:`diagnostics.fastpath.compiled`, beside
:mod:`diagnostics.fastpath.kernel`).

Along a map's coarse grid the parameters move a little from one row to the next, and so
does the Jacobian of the steady equations ``f(y; p) = 0``.  The rig's damped Newton solver
(:func:`sim.solver.rosenbrock.steady`) rebuilds its forward-difference Jacobian at every
iteration (one right-hand-side evaluation per state); the chord method (simplified Newton,
Deuflhard 2011, *Newton Methods for Nonlinear Problems*, §2.1.4, eq. 2.22)

.. math:: J_0\\,Δy_k = -f(y_k; p), \\qquad y_{k+1} = y_k + Δy_k

keeps the LU factors of ``J_0``, the Jacobian at the solution of an earlier row, and costs
one evaluation per iteration.  It converges linearly, with the contraction
``‖I − J_0⁻¹ J‖``: each iteration is accepted only while the scaled step shrinks by at least
half (:data:`CONTRACTION`), the first step must be small (the start is the continuation's
predictor, :data:`FIRST_STEP`), and it stops when the scaled step is below ``tol``
(:data:`CHORD_TOL` = 1e-10 on the maps: the solution error of a linear iteration is about
the contraction times the last step, seven orders under the readings' noise).  Otherwise
the row falls back to the damped solver, and the Jacobian is rebuilt at its solution (also
after a slow chord solve, more than :data:`REFRESH` iterations).

* :func:`newton_matrix` — the factored forward-difference Jacobian (``steady``'s);
* :func:`chord` — the iteration above;
* :func:`solve_grid` — both phases at every row of a grid, chord first (the fallback chain
  of :func:`diagnostics.fastpath.phase.phase_solve`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # bound in the generated module (see the module docstring)
    from diagnostics.fastpath.kernel import observables
    from diagnostics.fastpath.phase import drive, held_mask, phase_solve
    from diagnostics.fastpath.rig_interface import lu_factor, lu_solve, outputs, rhs

__all__ = ["CHORD_TOL", "CONSTANTS", "CONTRACTION", "FIRST_STEP", "FIT_TOL", "KERNELS",
           "MAX_CHORD", "REFRESH", "chord", "newton_matrix", "solve_grid"]

#: names copied into the generated module, in dependency order
KERNELS = ("newton_matrix", "chord", "solve_grid")
#: module constants copied into the generated module
CONSTANTS = ("CHORD_TOL", "FIT_TOL", "CONTRACTION", "FIRST_STEP", "MAX_CHORD", "REFRESH")

#: a chord step must shrink by this factor or the iteration is abandoned [-]
CONTRACTION = 0.5
#: largest scaled first step accepted (farther: not the continuation's root) [-]
FIRST_STEP = 0.25
#: a chord solve converged when its scaled step is below this [-]
CHORD_TOL = 1.0e-10
#: the same on the pair fits' evaluations, whose forward differences (steps of 1e-6 of
#: the range) need the solution to 1e-12 [-]
FIT_TOL = 1.0e-12
#: chord iterations at most [-]
MAX_CHORD = 12
#: a chord solve that took more iterations than this rebuilds the Jacobian at its
#: solution for the next row [-]
REFRESH = 4


def newton_matrix(y, p, mask, scale, jac, piv, f, yt, ft):  # type: ignore[no-untyped-def]
    """Forward-difference Jacobian of the rig's right-hand side at ``y`` over the states
    where ``mask`` is 1 (steps ``1.5e-8·max(|y_j|, scale_j)``, as ``steady``), LU-factored
    in place into ``jac``, ``piv``; False when singular or not finite."""
    n = y.size
    rhs(0.0, y, p, f)
    b = 0
    for j in range(n):
        if mask[j] == 0:
            continue
        d = 1.5e-8 * max(abs(y[j]), scale[j])
        for i in range(n):
            yt[i] = y[i]
        yt[j] = y[j] + d
        rhs(0.0, yt, p, ft)
        a = 0
        for i in range(n):
            if mask[i] != 0:
                jac[a, b] = (ft[i] - f[i]) / d
                a += 1
        b += 1
    for a in range(b):
        for c in range(b):
            if not math.isfinite(jac[a, c]):
                return False
    return lu_factor(jac, piv)


def chord(y0, p, mask, scale, tol, y, jac, piv, f, dy):  # type: ignore[no-untyped-def]
    """Chord iteration from ``y0`` with the factored ``jac``, ``piv`` (module docstring);
    the solution in ``y``.  Returns ``(why, iterations)``: ``why`` 0 when converged, else
    why not: 1 a step not finite, 2 the first step too large, 3 no contraction, 4 the
    iteration limit."""
    n = y0.size
    for i in range(n):
        y[i] = y0[i]
    prev = math.inf
    for it in range(MAX_CHORD):
        rhs(0.0, y, p, f)
        a = 0
        for i in range(n):
            if mask[i] != 0:
                dy[a] = -f[i]
                a += 1
        lu_solve(jac, piv, dy)
        step = 0.0
        a = 0
        for i in range(n):
            if mask[i] != 0:
                s = abs(dy[a]) / (scale[i] + abs(y[i]))
                if not s <= step:  # also takes a NaN
                    step = s
                y[i] += dy[a]
                a += 1
        if not math.isfinite(step):
            return 1, it + 1
        if step < tol:
            return 0, it + 1
        if it == 0 and step > FIRST_STEP:
            return 2, it + 1
        if step > CONTRACTION * prev:
            return 3, it + 1
        prev = step
    return 4, MAX_CHORD


def solve_grid(pw0, pr0, gidx, grid, mask, scale, last_w, last_r, nom_w, nom_r, oi, out,  # type: ignore[no-untyped-def]
               ok, nout, restart, use_chord, counts, creep, y0, ys, drv, jac, piv, valid,
               hjac, hpiv, hvalid):
    """Both phases' steady points and the observables at every row of ``grid`` (graph
    parameters ``gidx``); ``ok[k]`` False (and NaN) where no start converged.

    Along a run of rows (``restart`` 1 at a run's first row, which starts from the last
    solution; 2: from ``y0[k]``, one state per phase) the start is extrapolated from the
    previous solutions (the rows of a map are equally spaced): quadratically,
    ``3·y[k-1] − 3·y[k-2] + y[k-3]``, from the fourth row of a run, linearly,
    ``2·y[k-1] − y[k-2]``, at the third, else the last solution.  Each phase is solved by
    :func:`diagnostics.fastpath.phase.phase_solve` (with ``use_chord``, the chord
    iteration on the moving or the held state's Jacobian first; then the damped solver
    from the start, the last and the nominal solution; the end-stop state where the moving
    solution runs against the phase's direction).  ``last_*`` end as the last row's
    solutions.  ``counts`` adds the phase solves settled by the chord iteration (0), its
    failures by :func:`chord`'s reason (1-4), and the damped solves (5).  Out per row:
    ``ys[k]`` the solutions of both phases, ``drv[k]`` their
    :func:`~diagnostics.fastpath.phase.drive` at speed ``creep`` [m/s] (NaN where none).
    ``jac``, ``piv``, ``valid`` and ``hjac``, ``hpiv``, ``hvalid``: per phase the factored
    Jacobians of the moving and the held state (:func:`~diagnostics.fastpath.phase.
    phase_solve`), the caller's, so that a grid starts from the last one's (its context
    keeps them: the first row of a call is no longer a damped solve and a Jacobian built
    afresh for each phase).
    """
    pw = pw0.copy()
    pr = pr0.copy()
    ow = np.empty(nout)
    orr = np.empty(nout)
    ns = last_w.size
    m = jac.shape[1]
    hmask = held_mask(mask)
    f = np.empty(ns)
    ft = np.empty(ns)
    yt = np.empty(ns)
    dy = np.empty(m)
    y = np.empty(ns)
    prev = np.empty((2, 3, ns))
    start = np.empty(ns)
    run = 0
    for k in range(grid.shape[0]):
        if restart[k]:
            run = 0
        for j in range(gidx.size):
            pw[gidx[j]] = grid[k, j]
            pr[gidx[j]] = grid[k, j]
        done = True
        for ph in range(2):
            p = pw if ph == 0 else pr
            last = last_w if ph == 0 else last_r
            nom = nom_w if ph == 0 else nom_r
            for i in range(ns):
                if run >= 3:
                    start[i] = 3.0 * (prev[ph, 2, i] - prev[ph, 1, i]) + prev[ph, 0, i]
                elif run == 2:
                    start[i] = 2.0 * prev[ph, 2, i] - prev[ph, 1, i]
                elif run == 0 and restart[k] == 2:
                    start[i] = y0[k, ph, i]
                else:
                    start[i] = last[i]
            sign = 1.0 if ph == 0 else -1.0
            try_last = run >= 2 or (run == 0 and restart[k] == 2)
            if not phase_solve(start, last, nom, p, mask, hmask, scale, sign, CHORD_TOL, ph,
                               jac, piv, valid, hjac, hpiv, hvalid, use_chord, try_last,
                               counts, y, f, ft, yt, dy):
                done = False
                break
            for i in range(ns):
                last[i] = y[i]
                ys[k, ph, i] = y[i]
            drive(y, p, mask, sign, creep, yt, ft, drv[k, ph])
            outputs(0.0, y, p, ow if ph == 0 else orr)
        ok[k] = done
        if done:
            observables(ow, orr, oi, out[k])
            for ph in range(2):
                last = last_w if ph == 0 else last_r
                for i in range(ns):
                    prev[ph, 0, i] = prev[ph, 1, i]
                    prev[ph, 1, i] = prev[ph, 2, i]
                    prev[ph, 2, i] = last[i]
            run += 1
        else:
            for j in range(out.shape[1]):
                out[k, j] = np.nan
            for ph in range(2):
                drv[k, ph, 0] = np.nan
                drv[k, ph, 1] = np.nan
            run = 0
