"""One phase's steady point on the fast path: the one fallback chain of the maps' grid
solves and the pair fits (source compiled into the rig's generated numba module,
:mod:`diagnostics.fastpath.compiled`, beside :mod:`diagnostics.fastpath.kernel` and
:mod:`diagnostics.fastpath.chord`).

A phase is either *moving* (every state but the position steady) or *held* on its end
stop (the end-stop state of :mod:`sim.steady`: the piston's velocity state frozen at 0,
accepted where the held piston is pressed into its stop, ``−d·ẍ ≥ 0`` with ``d`` the
phase's commanded direction and ``ẍ`` the velocity equation's residual, paper 002 eq. 35
with ``m·ẍ = 0`` and the stop's reaction the unknown).  :func:`phase_solve` tries, in
this order:

1. where the start is held (its velocity state exactly 0): the chord iteration
   (:func:`diagnostics.fastpath.chord.chord`) on the held state's own factored Jacobian,
   then the damped Newton of :func:`end_stop`;
2. the chord iteration on the moving state's factored Jacobian, then the damped Newton
   (:func:`sim.solver.rosenbrock.steady`) from the start, the last and the nominal
   solution (a damped solve rebuilds the Jacobian at its solution);
3. where the moving solution runs against the phase's direction (or there is none): the
   end-stop state from the moving solution, the start, the last and the nominal one.

:func:`drive` gives the two quantities whose signs *are* the stroke states
(:mod:`diagnostics.stroke_state`), and :func:`held_grid` the end-stop state's drive along
a map's axis whatever the state there, from which the maps locate the moving, creeping
and held ridges (:mod:`diagnostics.fastpath.ridges`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # bound in the generated module (see the module docstring)
    from diagnostics.fastpath.chord import CHORD_TOL, REFRESH, chord, newton_matrix
    from diagnostics.fastpath.rig_interface import rhs, steady

__all__ = ["KERNELS", "drive", "end_stop", "held_grid", "held_mask", "phase_solve",
           "stop_index"]

#: names copied into the generated module, in dependency order
KERNELS = ("stop_index", "end_stop", "held_mask", "phase_solve", "drive", "held_grid")


def stop_index(mask):  # type: ignore[no-untyped-def]
    """Index of the piston's velocity state (``mask`` 2: solved when moving, held at 0 on
    the end stop); -1 if the mask marks none."""
    for i in range(mask.size):
        if mask[i] == 2:
            return i
    return -1


def held_mask(mask):  # type: ignore[no-untyped-def]
    """The solver mask of the end-stop state: the states ``mask`` marks 1 (the velocity
    state frozen with the position)."""
    held = np.empty(mask.size, dtype=np.int64)
    for i in range(mask.size):
        held[i] = 1 if mask[i] == 1 else 0
    return held


def end_stop(y0, p, mask, scale, sign, y):  # type: ignore[no-untyped-def]
    """The end-stop state (:mod:`sim.steady`) from ``y0`` into ``y`` (``y0`` may be ``y``):
    the velocity state held at 0, the states ``mask`` 1 steady (damped Newton); True when
    it converged and the held piston is pressed into its stop, ``−sign·ẍ ≥ 0`` (``sign``
    the phase's commanded direction, ``ẍ`` the velocity equation's residual)."""
    im = stop_index(mask)
    if im < 0:
        return False
    n = y0.size
    start = np.empty(n)
    for i in range(n):
        start[i] = y0[i]
    start[im] = 0.0
    if steady(start, p, held_mask(mask), scale, 1e-10, 60, y)[0] != 0:
        return False
    f = np.empty(n)
    rhs(0.0, y, p, f)
    return -sign * f[im] >= 0.0


def phase_solve(start, last, nom, p, mask, hmask, scale, sign, tol, ph, jac, piv, valid,  # type: ignore[no-untyped-def]
                hjac, hpiv, hvalid, use_chord, try_last, counts, y, f, ft, yt, dy):
    """One phase's steady point into ``y`` by the fallback chain of the module docstring;
    True when found.

    ``start`` the first start (a continuation's predictor or the last solution), ``last``
    and ``nom`` the later ones (``last`` tried by the damped solver only when
    ``try_last``: it differs from ``start``); ``hmask`` = :func:`held_mask` of ``mask``;
    ``tol`` the chord iterations' tolerance; ``jac``, ``piv``, ``valid`` and ``hjac``,
    ``hpiv``, ``hvalid`` per phase (index ``ph``) the factored Jacobians of the moving and
    the held state, rebuilt here at a damped solve's solution or after a slow chord solve;
    ``use_chord`` False: damped solves alone.  ``counts`` adds the moving phase solves
    settled by the chord iteration (0), its failures by reason (1-4,
    :func:`~diagnostics.fastpath.chord.chord`) and the damped solves (5).  ``f``, ``ft``,
    ``yt`` (length of ``y``) and ``dy`` (the moving Jacobian's order) are work arrays.
    """
    im = stop_index(mask)
    m = jac.shape[1]
    mh = hjac.shape[1]
    conv = False
    if im >= 0 and start[im] == 0.0:  # held before: its own chord, then damped
        if use_chord and hvalid[ph]:
            why, its = chord(start, p, hmask, scale, tol, y, hjac[ph], hpiv[ph], f, dy[:mh])
            if why == 0:
                rhs(0.0, y, p, f)
                conv = -sign * f[im] >= 0.0
                if conv and its > REFRESH:
                    hvalid[ph] = newton_matrix(y, p, hmask, scale, hjac[ph], hpiv[ph], f, yt,
                                               ft)
        if not conv:
            conv = end_stop(start, p, mask, scale, sign, y)
            if conv and use_chord:
                hvalid[ph] = newton_matrix(y, p, hmask, scale, hjac[ph], hpiv[ph], f, yt, ft)
        if conv:
            return True
    if use_chord and valid[ph]:
        why, its = chord(start, p, mask, scale, tol, y, jac[ph], piv[ph], f, dy[:m])
        conv = why == 0
        counts[why] += 1
        if conv and its > REFRESH:  # slow contraction: the Jacobian has moved
            valid[ph] = newton_matrix(y, p, mask, scale, jac[ph], piv[ph], f, yt, ft)
    if not conv:
        counts[5] += 1
        conv = steady(start, p, mask, scale, 1e-10, 60, y)[0] == 0
        if not conv and try_last:
            conv = steady(last, p, mask, scale, 1e-10, 60, y)[0] == 0
        if not conv:
            conv = steady(nom, p, mask, scale, 1e-10, 60, y)[0] == 0
        if conv and use_chord:
            valid[ph] = newton_matrix(y, p, mask, scale, jac[ph], piv[ph], f, yt, ft)
    if im >= 0 and not (conv and sign * y[im] >= 0.0):
        conv = conv and end_stop(y, p, mask, scale, sign, y)
        if not conv:
            conv = end_stop(start, p, mask, scale, sign, y)
        if not conv and try_last:
            conv = end_stop(last, p, mask, scale, sign, y)
        if not conv:
            conv = end_stop(nom, p, mask, scale, sign, y)
        if conv and use_chord:
            hvalid[ph] = newton_matrix(y, p, hmask, scale, hjac[ph], hpiv[ph], f, yt, ft)
    return conv


def drive(y, p, mask, sign, creep, yt, ft, out):  # type: ignore[no-untyped-def]
    """The drive of the piston at state ``y`` into ``out`` (two values, [m/s²]):
    ``sign·ẍ`` with the velocity state set to 0 and to ``sign·creep``, all else as ``y``.

    With friction a function of the speed alone (paper 002 eqs. 37, 51), the first is the
    friction (and viscous) force the pressures overcome over the mass,
    ``F(v)/m`` ≥ 0 on a moving or creeping stroke, and minus the stop's reaction over the
    mass on a held one: it is 0 exactly at the ridge between creeping and held.  The
    second is ``(F(v) − F(creep))/m``: ≥ 0 moving (speed ``creep`` [m/s] or more), < 0
    creeping or held, 0 at that ridge.  Both follow the pressures, smoothly along a map's
    axis on either side of a ridge (NaN without a velocity state)."""
    im = stop_index(mask)
    if im < 0:
        out[0] = np.nan
        out[1] = np.nan
        return
    for i in range(y.size):
        yt[i] = y[i]
    yt[im] = 0.0
    rhs(0.0, yt, p, ft)
    out[0] = sign * ft[im]
    yt[im] = sign * creep
    rhs(0.0, yt, p, ft)
    out[1] = sign * ft[im]


def held_grid(pw0, pr0, gidx, grid, phs, mask, scale, restart, y0, ys, g, ok):  # type: ignore[no-untyped-def]
    """The end-stop state of phase ``phs[k]`` (0 working, 1 return) at every row of
    ``grid`` (graph parameters ``gidx``), whether or not the held piston is pressed into
    its stop, and its drive ``g[k] = sign·ẍ`` [m/s²] (≤ 0: pressed into the stop, the
    phase is held; > 0: the pressures would move it).  Unlike the moving state, whose
    friction switches steeply in the creep band, this state has no switch: its drive is a
    smooth function of the parameters through the ridge between creeping and held, where
    it is 0.  A row with ``restart`` 1 starts from ``y0[k]`` (its velocity state set to
    0), else from the row before; chord iterations on the phase's held Jacobian first,
    then the damped solver.  ``ys[k]`` the solution; ``ok[k]`` False (``g`` NaN) where
    none converged."""
    pw = pw0.copy()
    pr = pr0.copy()
    hmask = held_mask(mask)
    im = stop_index(mask)
    n = mask.size
    mh = 0
    for i in range(n):
        mh += hmask[i]
    hjac = np.empty((2, mh, mh))
    hpiv = np.zeros((2, mh), dtype=np.int64)
    valid = np.zeros(2, dtype=np.bool_)
    f = np.empty(n)
    ft = np.empty(n)
    yt = np.empty(n)
    dy = np.empty(mh)
    y = np.empty(n)
    start = np.empty(n)
    have = False
    for k in range(grid.shape[0]):
        ph = phs[k]
        p = pw if ph == 0 else pr
        sign = 1.0 if ph == 0 else -1.0
        for j in range(gidx.size):
            p[gidx[j]] = grid[k, j]
        for i in range(n):
            start[i] = y0[k, i] if restart[k] or not have else y[i]
        if im >= 0:
            start[im] = 0.0
        conv = False
        if valid[ph]:
            why, its = chord(start, p, hmask, scale, CHORD_TOL, y, hjac[ph], hpiv[ph], f, dy)
            conv = why == 0
            if conv and its > REFRESH:
                valid[ph] = newton_matrix(y, p, hmask, scale, hjac[ph], hpiv[ph], f, yt, ft)
        if not conv:
            conv = steady(start, p, hmask, scale, 1e-10, 60, y)[0] == 0
            if conv:
                valid[ph] = newton_matrix(y, p, hmask, scale, hjac[ph], hpiv[ph], f, yt, ft)
        ok[k] = conv and im >= 0
        have = ok[k]
        if ok[k]:
            rhs(0.0, y, p, f)
            g[k] = sign * f[im]
            for i in range(n):
                ys[k, i] = y[i]
        else:
            g[k] = np.nan
