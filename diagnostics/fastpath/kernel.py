"""Compiled numerics of the fast inference path (source of a generated numba module).

These functions are not called from here: :mod:`diagnostics.fastpath.compiled` copies
their source into one generated module per rig, below
``from <rig module> import steady, outputs``, and compiles them there with numba
(``cache=True``: a second process loads the machine code).  ``steady`` is the rig's damped
Newton solver (:func:`sim.solver.rosenbrock.steady`, specialised to the rig's right-hand
side) and ``outputs`` its output function, declared in
:mod:`diagnostics.fastpath.rig_interface` (``.pyi``); nothing here is called as plain Python.

What is compiled here is what the direct path (:mod:`diagnostics.ranking`) does once per
model evaluation, in Python:

* :func:`solve_point` — both phases' steady operating points for one parameter vector
  (the fallback chain of :func:`diagnostics.fastpath.phase.phase_solve`, shared with the
  maps' grid solves: the chord iteration of :mod:`diagnostics.fastpath.chord` on the
  moving or the held state's Jacobian from the last solution, then Newton from the last
  solution and from the nominal one — the continuation of
  :class:`sim.steady.SteadyEvaluator` — and the end-stop state of :mod:`sim.steady` where
  the moving piston would run against its phase's direction) and the nine observables of
  :data:`diagnostics.signatures.OBSERVABLES` (speeds 0 on the stop, the velocity ratio
  NaN where the return stroke is held);
* the same over the rows of a matrix (a signature map's coarse grid) is
  :func:`diagnostics.fastpath.chord.solve_grid`, with a chord Newton;
* :func:`pair_fit` — the Levenberg-Marquardt fit of a two-parameter hypothesis over all
  records (forward-difference Jacobians of step 1e-6 of the range, a masked reading a
  miss of ``masked`` σ), the exact iteration of ``Ranker.fit_pair``;
* :func:`profile_points` — the profile of ``Ranker._profile_evidence``: along the weak
  axis, the strong parameter fitted by Gauss-Newton, χ² and the curvature returned;
* masked PCHIP, the interpolation of :func:`diagnostics.signatures.masked_pchip`, is in
  :mod:`diagnostics.fastpath.pchip` and compiled into the same module.

The evidences and probabilities are *not* here: the caller combines these numbers with
the same Python functions the direct path uses.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # bound in the generated module (see the module docstring)
    from diagnostics.fastpath.chord import FIT_TOL
    from diagnostics.fastpath.phase import held_mask, phase_solve
    from diagnostics.fastpath.rig_interface import outputs

__all__ = ["KERNELS", "graph_values", "observables", "pair_fit", "profile_points", "residuals",
           "solve_point"]

#: names copied into the generated module, in dependency order
KERNELS = ("observables", "solve_point", "graph_values",
           "residuals", "pair_fit", "profile_points")


def observables(w, r, oi, out):  # type: ignore[no-untyped-def]
    """The nine observables from the working (``w``) and return (``r``) outputs.

    ``oi`` = output indices of P_pump, P1, P2, Q_meter_B, Q_meter_C, Q_relief, v.
    """
    out[0] = w[oi[0]]
    out[1] = w[oi[1]]
    out[2] = w[oi[2]]
    out[3] = w[oi[3]]
    out[4] = w[oi[4]]
    out[5] = w[oi[3]] + w[oi[5]]
    vw = w[oi[6]]
    vr = r[oi[6]]
    out[6] = vw
    out[7] = -vr
    out[8] = vw / -vr if vr < 0.0 else np.nan


def solve_point(pw, pr, mask, hmask, scale, states, jac, piv, valid, hjac, hpiv, hvalid, oi,  # type: ignore[no-untyped-def]
                ow, orr, work, counts, out):
    """Both phases of one record at one parameter vector pair; True when both converged.

    ``states`` = last working, last return, nominal working, nominal return (the last ones
    updated on success).  Each phase by :func:`diagnostics.fastpath.phase.phase_solve`
    from the last solution (the continuation of :class:`sim.steady.SteadyEvaluator`):
    the chord iteration (scaled step below ``FIT_TOL``) on the factored Jacobian of the
    moving (``jac``, ``piv``, ``valid``) or, where the last point was held on its end stop,
    the held state (``hjac``, ``hpiv``, ``hvalid``), per phase; then the damped Newton from
    the last and the nominal solution; the end-stop state where the moving solution runs
    against the phase's direction.  ``hmask`` = :func:`~diagnostics.fastpath.phase.held_mask`
    of ``mask``; ``work`` = rows y, f, f_trial, y_trial, dy; ``counts`` as
    :func:`~diagnostics.fastpath.chord.solve_grid`'s.  On failure ``out`` is NaN (the caller
    may retry from a start-up transient).
    """
    y = work[0]
    f = work[1]
    ft = work[2]
    yt = work[3]
    dy = work[4]
    for ph in range(2):
        p = pw if ph == 0 else pr
        sign = 1.0 if ph == 0 else -1.0
        last = states[ph]
        if not phase_solve(last, last, states[2 + ph], p, mask, hmask, scale, sign, FIT_TOL,
                           ph, jac, piv, valid, hjac, hpiv, hvalid, True, False, counts, y, f,
                           ft, yt, dy):
            for j in range(out.size):
                out[j] = np.nan
            return False
        for i in range(y.size):
            last[i] = y[i]
        outputs(0.0, y, p, ow if ph == 0 else orr)
    observables(ow, orr, oi, out)
    return True


def graph_values(z, base, which, tlog, tmode, tconst, g):  # type: ignore[no-untyped-def]
    """Graph parameter vector with the fitted parameters at fitting coordinates ``z``.

    Parameter ``j`` sets graph parameter ``which[j]`` to ``c·v`` (``tmode 0``) or ``c/v``
    (``tmode 1``), ``v = exp(z)`` for a log prior (``tlog 1``) else ``z``.
    """
    for i in range(base.size):
        g[i] = base[i]
    for j in range(z.size):
        v = math.exp(z[j]) if tlog[j] else z[j]
        g[which[j]] = tconst[j] * v if tmode[j] == 0 else tconst[j] / v


def residuals(z, prob, masked, r, fulls):  # type: ignore[no-untyped-def]
    """Whitened residuals of all records at ``z``; returns χ², ``fulls[k]`` record k's
    observables.

    ``prob`` = (``ctx_p``: per record its working and return parameter vectors,
    ``ctx_i``: per record its states (last working, last return, nominal working,
    nominal return), solver ``mask``, state ``scale``, output indices ``oi``, graph
    values ``base``, their indices ``gidx`` in the parameter vector, the fitted
    parameters' ``which``, ``tlog``, ``tmode``, ``tconst`` (:func:`graph_values`), readings
    ``yobs``, their marginal ``sig``, the whitening rows ``wrow`` (row ``a`` of the
    reading's record's matrix W, :class:`diagnostics.record_model.RecordModel`, over that
    record's readings), observable index ``oidx``, record ``start`` offsets, the number of
    model outputs ``nout``, per record its phases' factored Jacobians ``ctx_j``, pivots
    ``ctx_piv`` and whether they hold one, ``ctx_v``, and the same of the held state
    ``ctx_hj``, ``ctx_hpiv``, ``ctx_hv`` (:func:`solve_point`)).  Record k's
    residuals are ``W_k (y − ŷ)``; a record with a reading without prediction falls back
    to residuals per marginal σ, that reading counting ``masked`` σ (as
    :func:`diagnostics.pair_direct.residuals`).
    """
    (ctx_p, ctx_i, mask, scale, oi, base, gidx, which, tlog, tmode, tconst, yobs, sig, wrow,
     oidx, start, nout, ctx_j, ctx_piv, ctx_v, ctx_hj, ctx_hpiv, ctx_hv) = prob
    d = np.empty(wrow.shape[1])
    g = np.empty(base.size)
    graph_values(z, base, which, tlog, tmode, tconst, g)
    ow = np.empty(nout)
    orr = np.empty(nout)
    work = np.empty((5, ctx_i.shape[2]))
    hmask = held_mask(mask)
    counts = np.zeros(6, dtype=np.int64)
    for k in range(ctx_p.shape[0]):
        pw = ctx_p[k, 0].copy()
        pr = ctx_p[k, 1].copy()
        for j in range(gidx.size):
            pw[gidx[j]] = g[j]
            pr[gidx[j]] = g[j]
        solve_point(pw, pr, mask, hmask, scale, ctx_i[k], ctx_j[k], ctx_piv[k], ctx_v[k],
                    ctx_hj[k], ctx_hpiv[k], ctx_hv[k], oi, ow, orr, work, counts, fulls[k])
        s0 = start[k]
        n = start[k + 1] - s0
        finite = True
        for i in range(n):
            d[i] = yobs[s0 + i] - fulls[k, oidx[s0 + i]]
            if not math.isfinite(d[i]):
                finite = False
        for i in range(n):
            if finite:
                acc = 0.0
                for j in range(n):
                    acc += wrow[s0 + i, j] * d[j]
                r[s0 + i] = acc
            else:
                v = d[i] / sig[s0 + i]
                r[s0 + i] = v if math.isfinite(v) else masked
    cost = 0.0
    for a in range(r.size):
        cost += r[a] * r[a]
    return cost


def pair_fit(z0, zl, zu, prob, masked, jac, r, fulls):  # type: ignore[no-untyped-def]
    """Levenberg-Marquardt of ``Ranker.fit_pair`` from ``z0``; returns ``(z, cost)``.

    On return ``jac`` holds the last Jacobian computed (at the estimate before the last
    accepted step, as in the direct path), ``r`` and ``fulls`` the residuals and
    observables at the estimate.
    """
    n = r.size
    span = zu - zl
    z = z0.copy()
    cost = residuals(z, prob, masked, r, fulls)
    lam = 1e-3
    rj = np.empty(n)
    rn = np.empty(n)
    fn = np.empty_like(fulls)
    fj = np.empty_like(fulls)
    zj = np.empty(2)
    h = np.empty((2, 2))
    g = np.empty(2)
    for _ in range(15):
        for j in range(2):
            dz = 1e-6 * span[j]
            zj[0] = z[0]
            zj[1] = z[1]
            zj[j] = zj[j] + dz if zj[j] + dz <= zu[j] else zj[j] - dz
            residuals(zj, prob, masked, rj, fj)
            for a in range(n):
                jac[a, j] = (rj[a] - r[a]) / (zj[j] - z[j])
        for i in range(2):
            g[i] = 0.0
            for a in range(n):
                g[i] += jac[a, i] * r[a]
            for j in range(2):
                s = 0.0
                for a in range(n):
                    s += jac[a, i] * jac[a, j]
                h[i, j] = s
        improved = False
        moved = 0.0
        gain = 0.0
        while lam < 1e8:
            a00 = h[0, 0] + lam * (h[0, 0] + 1e-30)
            a11 = h[1, 1] + lam * (h[1, 1] + 1e-30)
            a01 = h[0, 1]
            a10 = h[1, 0]
            det = a00 * a11 - a01 * a10
            s0 = -(a11 * g[0] - a01 * g[1]) / det
            s1 = -(a00 * g[1] - a10 * g[0]) / det
            # a coordinate on its bound that the step pushes outward stays there, and the
            # other takes its own damped step (projected Levenberg-Marquardt, as
            # pair_direct.levenberg_marquardt): the clipped full step stalled fits on a
            # bound at χ² 11 where the free coordinate alone reached 0.1 (a user pass)
            out0 = (z[0] <= zl[0] and s0 < 0.0) or (z[0] >= zu[0] and s0 > 0.0)
            out1 = (z[1] <= zl[1] and s1 < 0.0) or (z[1] >= zu[1] and s1 > 0.0)
            if out1 and not out0:
                s0 = -g[0] / a00
                s1 = 0.0
            elif out0 and not out1:
                s0 = 0.0
                s1 = -g[1] / a11
            zn0 = min(max(z[0] + s0, zl[0]), zu[0])
            zn1 = min(max(z[1] + s1, zl[1]), zu[1])
            zj[0] = zn0
            zj[1] = zn1
            cn = residuals(zj, prob, masked, rn, fn)
            if cn < cost:
                improved = True
                moved = max(abs(zn0 - z[0]) / span[0], abs(zn1 - z[1]) / span[1])
                gain = cost - cn
                z[0] = zn0
                z[1] = zn1
                for a in range(n):
                    r[a] = rn[a]
                fulls[:, :] = fn
                cost = cn
                lam = max(lam / 10.0, 1e-9)
                break
            lam *= 10.0
        if not improved or moved < 1e-4 or gain < 1e-3:
            break
    return z, cost


def profile_points(z_hat, slope, weak, grid, zl, zu, prob, masked, chi2, hss, zs):  # type: ignore[no-untyped-def]
    """Profile of ``Ranker._profile_evidence``: at each weak-axis point ``grid[k]`` the
    strong parameter by Gauss-Newton (4 steps at most); ``chi2[k]``, its curvature
    ``hss[k]`` (J·J) and the strong coordinate ``zs[k]`` out."""
    strong = 1 - weak
    span = zu - zl
    n = prob[11].size
    r = np.empty(n)
    rp = np.empty(n)
    rn = np.empty(n)
    jv = np.empty(n)
    fulls = np.empty((prob[0].shape[0], 9))
    z = z_hat.copy()
    zp = np.empty(2)
    zn = np.empty(2)
    for k in range(grid.size):
        z[weak] = grid[k]
        z[strong] = min(max(z_hat[strong] + slope * (grid[k] - z_hat[weak]), zl[strong]),
                        zu[strong])
        c = residuals(z, prob, masked, r, fulls)
        h_ss = 0.0
        for _ in range(4):
            dz = 1e-6 * span[strong]
            zp[0] = z[0]
            zp[1] = z[1]
            zp[strong] = zp[strong] + dz if zp[strong] + dz <= zu[strong] else zp[strong] - dz
            residuals(zp, prob, masked, rp, fulls)
            jr = 0.0
            h_ss = 0.0
            for a in range(n):
                jv[a] = (rp[a] - r[a]) / (zp[strong] - z[strong])
                h_ss += jv[a] * jv[a]
                jr += jv[a] * r[a]
            if h_ss <= 0:
                break
            zn[0] = z[0]
            zn[1] = z[1]
            zn[strong] = min(max(z[strong] - jr / h_ss, zl[strong]), zu[strong])
            cn = residuals(zn, prob, masked, rn, fulls)
            if cn >= c:
                break
            step = abs(zn[strong] - z[strong])
            z[0] = zn[0]
            z[1] = zn[1]
            for a in range(n):
                r[a] = rn[a]
            c = cn
            if step < 1e-4 * span[strong]:
                break
        chi2[k] = c
        hss[k] = h_ss
        zs[k] = z[strong]
