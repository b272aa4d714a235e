"""One-parameter hypothesis fits of the fast path on the signature maps, in one compiled
call (source compiled into the rig's generated numba module,
:mod:`diagnostics.fastpath.compiled`).

:func:`single_scan` is the arithmetic of :meth:`diagnostics.ranking.Ranker.fit_single`
(the direct path's numpy form is the reference of the equivalence test): over the
``n`` points ``z_k`` of a hypothesis's map, with whitened residuals of every record
(:class:`diagnostics.record_model.RecordModel`; a record with a masked prediction
counts χ² = ∞ there),

.. math:: χ²_k = \\sum_{records} |W (y − ŷ(z_k))|², \\qquad
          \\ln Z = \\max_k ℓ_k + \\ln \\frac{1}{n}\\sum_k e^{ℓ_k − \\max ℓ}, \\quad ℓ = −χ²/2

(the evidence integral of :mod:`diagnostics.ranking` on the uniform grid); the estimate is
the first point within ``tie`` of the maximum, refined by a parabola through its
neighbours; the 95 % interval by :func:`posterior_interval`; the detectability
``max_k sqrt(Σ ((ŷ(z_k) − ŷ₀)/σ)²)`` against the healthy prediction.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["CONSTANTS", "KERNELS", "LAPLACE_SPACINGS", "interp_monotone", "posterior_interval",
           "single_scan"]

#: names copied into the generated module, in dependency order
KERNELS = ("interp_monotone", "posterior_interval", "single_scan")
#: module constants copied into the generated module (:mod:`diagnostics.fastpath.compiled`)
CONSTANTS = ("LAPLACE_SPACINGS",)

#: a posterior whose Laplace standard deviation is at most this many grid spacings takes
#: the Laplace interval (:func:`posterior_interval`) [-]
LAPLACE_SPACINGS = 2.0


def interp_monotone(x, xp, fp):  # type: ignore[no-untyped-def]
    """``numpy.interp(x, xp, fp)`` for a non-decreasing ``xp``: the last node at or below
    ``x``, linear to the next one; ``fp`` at the ends outside."""
    n = xp.size
    if x < xp[0]:
        return fp[0]
    if x >= xp[n - 1]:
        return fp[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:  # xp[lo] <= x < xp[hi]
        mid = (lo + hi) // 2
        if xp[mid] <= x:
            lo = mid
        else:
            hi = mid
    slope = (fp[hi] - fp[lo]) / (xp[hi] - xp[lo])
    return slope * (x - xp[lo]) + fp[lo]


def posterior_interval(z, post, zk, den):  # type: ignore[no-untyped-def]
    """95 % interval [fitting coordinate] of a one-parameter posterior known at the equally
    spaced points ``z`` (``post``: its density there, any scale), estimate ``zk``.

    ``den`` = ℓ_{k−1} − 2ℓ_k + ℓ_{k+1} of the log-likelihood ℓ at the best point and its
    neighbours (NaN where there is no parabola: the best point at an end, or beside a
    masked one).  Where the parabola gives a Laplace standard deviation σ = h/√(−den) of
    at most :data:`LAPLACE_SPACINGS` grid spacings h, the posterior is too narrow for the
    grid to resolve and the interval is ẑ ± 1.96σ, clipped to the axis.  Otherwise the
    2.5 % and 97.5 % points of the cumulative integral of the density interpolated
    linearly between the points (the trapezoid rule; linear between points), widened to
    hold the estimate.  (The interval was once read off the cumulative *sum* of the
    point masses, which puts each point's mass on the interval before it: half a grid
    spacing low.  On its own this moved the accuracy study's coverage little — the
    intervals that missed were missing the stated condition's uncertainty,
    :mod:`diagnostics.condition_interval`.)"""
    n = z.size
    h = z[1] - z[0]
    if den < 0.0 and math.isfinite(den):
        sd = h / math.sqrt(-den)
        if sd <= LAPLACE_SPACINGS * h:
            return max(zk - 1.96 * sd, z[0]), min(zk + 1.96 * sd, z[n - 1])
    cdf = np.empty(n)
    cdf[0] = 0.0
    for k in range(1, n):
        cdf[k] = cdf[k - 1] + 0.5 * (post[k - 1] + post[k])
    total = cdf[n - 1]
    if not total > 0.0:  # all the mass on one end point
        return zk, zk
    for k in range(n):
        cdf[k] /= total
    lo = min(interp_monotone(0.025, cdf, z), zk)
    hi = max(interp_monotone(0.975, cdf, z), zk)
    return lo, hi


def single_scan(z, preds, nominal, yobs, wrow, sig, oidx, start, tie, chi2):  # type: ignore[no-untyped-def]
    """The numbers of a one-parameter fit (module docstring).

    ``z`` the map's axis (``n`` points, equally spaced), ``preds[m, k]`` record ``m``'s
    nine observables at ``z_k``, ``nominal[m]`` its healthy ones; the readings ``yobs``,
    whitening rows ``wrow``, marginal ``sig``, observable indices ``oidx`` and record
    ``start`` offsets as :func:`diagnostics.fastpath.kernel.residuals` takes them;
    ``chi2`` (``n``) receives χ²_k.  Returns ``(top, ln Z, k, z estimate, z low, z high,
    detectability)``; ``top`` = −∞ when no point has a prediction for the readings
    (then the rest is the first point's).
    """
    n = z.size
    detect = np.zeros(n)
    for k in range(n):
        chi2[k] = 0.0
    for m in range(preds.shape[0]):
        s0 = start[m]
        nr = start[m + 1] - s0
        for k in range(n):
            c = 0.0
            dd = 0.0
            for i in range(nr):
                acc = 0.0
                for j in range(nr):
                    acc += wrow[s0 + i, j] * (yobs[s0 + j] - preds[m, k, oidx[s0 + j]])
                c += acc * acc
                e = (preds[m, k, oidx[s0 + i]] - nominal[m, oidx[s0 + i]]) / sig[s0 + i]
                dd += e * e
            chi2[k] += math.inf if math.isnan(c) else c
            detect[k] += dd
    dmax = 0.0
    for k in range(n):
        d = detect[k]
        if math.isfinite(d) and d > dmax:  # NaN and ∞ count 0 (numpy.nan_to_num)
            dmax = d
    detectability = math.sqrt(dmax)
    top = -math.inf
    for k in range(n):
        if -0.5 * chi2[k] > top:
            top = -0.5 * chi2[k]
    if not math.isfinite(top):
        return top, -math.inf, 0, z[0], z[0], z[n - 1], detectability
    total = 0.0
    post = np.empty(n)
    for k in range(n):
        post[k] = math.exp(-0.5 * chi2[k] - top)
        total += post[k]
    log_ev = top + math.log(total / n)
    best = 0
    for k in range(n):
        if -0.5 * chi2[k] >= top - tie:
            best = k
            break
    zk = z[best]
    den = math.nan
    if 0 < best < n - 1:
        y0 = -0.5 * chi2[best - 1]
        y1 = -0.5 * chi2[best]
        y2 = -0.5 * chi2[best + 1]
        den = y0 - 2 * y1 + y2
        if den < 0 and math.isfinite(den):
            zk += 0.5 * (y0 - y2) / den * (z[1] - z[0])
    lo, hi = posterior_interval(z, post, zk, den)
    return top, log_ev, best, zk, lo, hi, detectability
