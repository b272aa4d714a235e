"""Theil–Sen slope with Sen's (1968) rank interval, for long series too.

:func:`theil_sen` gives the numbers of ``scipy.stats.theilslopes(y, t, alpha=confidence)``
(slope: median of the pairwise slopes; interval from Kendall's τ, Sen 1968 eq. 2.6)
without the n × n difference matrices and the full sort of the slopes: the few order
statistics it needs are found by partial partition, O(n²) instead of O(n² log n); above
:data:`EXACT_PAIRS` points the slopes of :data:`SAMPLED_PAIRS` random pairs stand for all
of them.  Used by :mod:`diagnostics.trends`.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy import stats

from sim.errors import InputError

__all__ = ["EXACT_PAIRS", "SAMPLED_PAIRS", "theil_sen"]


def _tie_term(a: npt.NDArray[np.float64]) -> int:
    """Σ k(k − 1)(2k + 5) over the groups of k ≥ 2 equal values of ``a`` (Sen 1968 eq. 2.6)."""
    _, counts = np.unique(a, return_counts=True)
    k = counts[counts > 1].astype(np.int64)
    return int(np.sum(k * (k - 1) * (2 * k + 5)))


def theil_sen(t: npt.ArrayLike, y: npt.ArrayLike, *, confidence: float = 0.95
              ) -> tuple[float, float, float]:
    """Theil–Sen slope and its rank interval: ``(slope, low, high)`` [unit of y / unit of t].

    The numbers of ``scipy.stats.theilslopes(y, t, alpha=confidence)`` (slope: median of
    the slopes ``(yⱼ − yᵢ)/(tⱼ − tᵢ)`` over the pairs with ``tⱼ > tᵢ``; interval: the order
    statistics of the slopes at ``(N ∓ z·σ)/2``, σ² from Sen 1968 eq. 2.6 with ties in t
    and y), computed from the pairs of the series sorted by time (ties by value: the
    answer does not depend on the order of the points) and a partial partition.

    Raises
    ------
    InputError
        Fewer than two distinct times.
    """
    tt = np.asarray(t, dtype=np.float64).ravel()
    yy = np.asarray(y, dtype=np.float64).ravel()
    # by time, ties by value: the sampled pairs of a long series index this order, and
    # estimates at one time in the order they came (the store's rows) moved the slope by
    # 1.3 % (2,600 points, two per time; a determinism pass)
    order = np.lexsort((yy, tt))
    ts, ys = tt[order], yy[order]
    n = ts.size
    alpha = 1.0 - confidence if confidence > 0.5 else confidence
    z = float(stats.norm.ppf(alpha / 2.0))
    ny = yy.size
    sigsq = 1 / 18.0 * (ny * (ny - 1) * (2 * ny + 5) - _tie_term(tt) - _tie_term(yy))
    sigma = math.sqrt(sigsq) if sigsq >= 0 else math.nan
    if n > EXACT_PAIRS:
        return _sampled_theil_sen(ts, ys, z, sigma)
    dt = np.empty(n * (n - 1) // 2)
    dy = np.empty_like(dt)
    at = 0
    for lag in range(1, n):  # the pairs (i, i + lag), one vector operation per lag
        np.subtract(ts[lag:], ts[:-lag], out=dt[at:at + n - lag])
        np.subtract(ys[lag:], ys[:-lag], out=dy[at:at + n - lag])
        at += n - lag
    keep = dt > 0
    slopes = dy[keep] / dt[keep]
    nt = slopes.size
    if nt == 0:
        raise InputError("a slope needs two distinct times", field="times")
    mid = [(nt - 1) // 2, nt // 2]
    bounds: list[int] = []
    if math.isfinite(sigma):
        bounds = [max(int(np.round((nt + z * sigma) / 2.0)) - 1, 0),
                  min(int(np.round((nt - z * sigma) / 2.0)), nt - 1)]
    part = np.partition(slopes, sorted(set(mid + bounds)))
    slope = float(part[mid[0]]) if nt % 2 else float(np.mean(part[mid]))
    if not bounds:
        return slope, math.nan, math.nan
    return slope, float(part[bounds[0]]), float(part[bounds[1]])


#: most points whose pairs :func:`theil_sen` forms all (2 million pairs, 64 MB); above it
#: the slopes of :data:`SAMPLED_PAIRS` random pairs stand for them (a rig diagnosed every
#: few minutes for a year, 35,000 points, made 6e8 pairs: 21 GB and 40 s for one trends
#: request, a fleet integrator's pass)
EXACT_PAIRS = 2000
#: pairs drawn when a series is longer than :data:`EXACT_PAIRS` [-]: the order statistics
#: become quantiles, whose sampling error (√(q(1 − q)/M) ≈ 7e-4) is well inside the
#: interval's own width in rank fraction (≈ 2z/(3√n), 0.03 at n = 2000); 2 million took
#: 0.19 s a component, the most of a trends request at 12,600 points (an operator pass)
SAMPLED_PAIRS = 500_000


def _sampled_theil_sen(ts: npt.NDArray[np.float64], ys: npt.NDArray[np.float64], z: float,
                       sigma: float
                       ) -> tuple[float, float, float]:
    """:func:`theil_sen` from :data:`SAMPLED_PAIRS` random pairs of the time-sorted series
    (a fixed seed: the same series gives the same numbers): the median slope, and the rank
    interval's order statistics as quantiles at the same fractions of all pairs."""
    n = ts.size
    rng = np.random.default_rng(0)
    i = rng.integers(0, n, SAMPLED_PAIRS)
    j = rng.integers(0, n, SAMPLED_PAIRS)
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    dt = ts[hi] - ts[lo]
    keep = dt > 0
    if not keep.any():
        raise InputError("a slope needs two distinct times", field="times")
    slopes = (ys[hi] - ys[lo])[keep] / dt[keep]
    m = slopes.size
    mid = [(m - 1) // 2, m // 2]
    if not math.isfinite(sigma):
        part = np.partition(slopes, mid)
        return float(np.mean(part[mid])), math.nan, math.nan
    # the pairs with distinct times among all n(n − 1)/2, as the sample counts them
    total = float(np.mean(keep[i != j])) * n * (n - 1) / 2.0
    fractions = [min(max((total + z * sigma) / (2.0 * total), 0.0), 1.0),
                 min(max((total - z * sigma) / (2.0 * total), 0.0), 1.0)]
    # one partial partition for the median and both ends (as np.quantile's 'linear' rule
    # reads them, its two neighbours each), not three sorts
    at = [f * (m - 1) for f in fractions]
    ranks = sorted({*mid, *(math.floor(a) for a in at),
                    *(min(math.floor(a) + 1, m - 1) for a in at)})
    part = np.partition(slopes, ranks)
    ends = []
    for a in at:
        k = math.floor(a)
        upper = part[min(k + 1, m - 1)]
        ends.append(float(part[k] + (a - k) * (upper - part[k])))
    return float(np.mean(part[mid])), ends[0], ends[1]
