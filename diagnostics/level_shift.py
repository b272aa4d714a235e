"""A step in a trend's level: a contamination event, a part swapped, wear that sped up.

A straight line through a history with a step in it reads the step as steady wear: a
spool clearance that jumped from 34 to 46 µm and then stayed was forecast "worsening,
reaches 54 µm in 78 days" (a maintenance planner's pass).  :func:`level_shift` tests the
line ``y = a + b·t`` against a line with one step, ``y = a + b·t + d·[t ≥ τ]``, over
every split τ between visits that leaves :data:`MIN_SIDE` visits (and 15 % of them) on
each side: the largest F statistic of the step (Andrews 1993's sup-F, one break,
trimming 0.15) against its 1 % point at the history's number of visits
(:data:`CRITICAL_F`, found by simulating straight lines with Gaussian scatter).  Every
split's F comes from running sums (O(n) for the 35,000 visits of a rig diagnosed every
cycle).  Before the test, each residual from the robust (Theil–Sen) line is clipped at 3
robust σ, so one record with a wrong date is not a step; a step must also be larger than
:data:`PRACTICAL` times the visits' typical stated uncertainty, on the less certain side
of the step (hundreds of visits make a quarter-σ step significant, and the estimates' own
level-dependent biases are of that size).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.robust import mad_sigma

__all__ = ["CRITICAL_F", "MIN_SIDE", "MIN_VISITS", "PRACTICAL", "LevelShift", "critical_f",
           "level_shift"]

#: fewest visits on each side of a step
MIN_SIDE = 4
#: fewest visits for the test (below it a step and a slope cannot be told apart)
MIN_VISITS = 10
#: trimming: each side keeps at least this share of the visits
TRIM = 0.15
#: 1 % critical values of the sup-F statistic (one break, trimming as above) by number of
#: visits: the 99th percentile of 2,000 straight lines with Gaussian scatter (600 at 400
#: visits), the larger of two runs where both ran (``make trend-study`` repeats it; the
#: percentile moves by about 10 % between runs), residuals clipped as the test clips
#: them; Andrews (1993) Table I gives 12.35 for many visits
CRITICAL_F: tuple[tuple[int, float], ...] = (
    (10, 22.2), (15, 16.8), (25, 16.3), (40, 15.1), (100, 13.5), (400, 14.0))
#: a step smaller than this many typical standard uncertainties of one visit is not
#: reported, however significant
PRACTICAL = 2.0


@dataclass(frozen=True, slots=True)
class LevelShift:
    """A step found in a history.

    Attributes
    ----------
    time
        Midpoint between the last visit before and the first after it [s].
    size
        The step [unit of the series].
    f_stat
        Its F statistic [-].
    """

    time: float
    size: float
    f_stat: float


def critical_f(n: int) -> float:
    """The 1 % critical sup-F at ``n`` visits: :data:`CRITICAL_F` interpolated in log n
    (its last value beyond it)."""
    ns = np.log([float(k) for k, _ in CRITICAL_F])
    fs = [f for _, f in CRITICAL_F]
    return float(np.interp(math.log(max(n, 1)), ns, fs))


def _sup_f(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64], lo: int, hi: int
           ) -> tuple[int, float, float]:
    """Split index in [lo, hi] with the largest F of a step, its F and its size."""
    n = t.size
    # suffix sums for the step column d_k = [i ≥ k]
    s1 = np.cumsum(np.ones(n)[::-1])[::-1]
    st = np.cumsum(t[::-1])[::-1]
    sy = np.cumsum(y[::-1])[::-1]
    k = np.arange(lo, hi + 1)
    m, mt, my = s1[k], st[k], sy[k]
    # with t and y centred (Σt = Σy = 0): X'X = [[n, 0, m], [0, Stt, mt], [m, mt, m]]
    stt, sty, syy = float(t @ t), float(t @ y), float(y @ y)
    # the step's coefficient by partialling the intercept and the slope out of d
    dd = m - m * m / n - mt * mt / stt
    dy = my - mt * sty / stt     # Σy = 0: no intercept term
    rss_line = syy - sty * sty / stt
    gain = np.where(dd > 0, dy * dy / np.where(dd > 0, dd, 1.0), 0.0)
    rss_step = np.maximum(rss_line - gain, 1e-300)
    f = gain / (rss_step / (n - 3))
    j = int(np.argmax(f))
    size = float(dy[j] / dd[j]) if dd[j] > 0 else 0.0
    return int(k[j]), float(f[j]), size


def level_shift(times: npt.ArrayLike, values: npt.ArrayLike, slope: float,
                typical_u: float | npt.ArrayLike | None = None) -> LevelShift | None:
    """The step in ``values`` at ``times`` [s] (a trend with Theil–Sen ``slope`` [unit/s]),
    or None when there is none the test can show (module docstring); ``typical_u``: the
    visits' typical stated standard uncertainty [unit] (the practical size), or each
    visit's, or None.  With each visit's, the practical size is that of the less certain
    side of the step (the larger of the two sides' medians): four visits at a light load
    and cold oil (u 14-19 µm) read 11.7 µm below 22 at full load (u 1-3 µm) and made a
    healthy seal's "step", smaller than one σ of the visits it rested on (a reliability
    engineer's pass)."""
    t = np.asarray(times, dtype=np.float64)
    y = np.asarray(values, dtype=np.float64)
    order = np.argsort(t, kind="stable")
    t, y = t[order], y[order]
    u = None if typical_u is None or np.ndim(typical_u) == 0 else \
        np.asarray(typical_u, dtype=np.float64)[order]
    n = t.size
    lo = max(MIN_SIDE, math.ceil(TRIM * n))
    hi = n - lo
    if n < MIN_VISITS or hi < lo:
        return None
    dt = t - float(np.median(t))
    res = y - slope * dt
    res = res - float(np.median(res))
    sigma = mad_sigma(res)
    if sigma > 0:   # one wrong record is not a step
        res = np.clip(res, -3 * sigma, 3 * sigma)
    yc = res + slope * dt
    tc = dt / max(float(t[-1] - t[0]), 1.0)
    tc = tc - tc.mean()
    yc = yc - yc.mean()
    if float(tc @ tc) <= 0.0:
        return None
    k, f, size = _sup_f(tc, yc, lo, hi)
    if t[k] == t[k - 1] or f < critical_f(n):
        return None
    # its size from the readings as they are: the clipping that keeps one wrong record
    # from making a step also cut a repair's 35 µm drop to 9 µm (a reliability engineer)
    raw = y - float(np.mean(y))
    size = _sup_f(tc, raw, k, k)[2]
    typical = (max(float(np.median(u[:k])), float(np.median(u[k:]))) if u is not None
               else None if typical_u is None else float(typical_u))  # type: ignore[arg-type]
    floor = PRACTICAL * (typical if typical is not None and typical > 0 else sigma)
    if abs(size) < floor:
        return None
    return LevelShift(0.5 * float(t[k - 1] + t[k]), size, f)
