"""Trends of a diagnosed parameter over visits, and the time left to a threshold.

A :class:`TrendSeries` is one rig's history of one component's parameter (``cc``, ``cv``,
``Cs``): times [s] (any common origin, e.g. Unix time), estimates and their standard
uncertainties.

Slope (:func:`fit_trend`)
    Theil–Sen (Sen 1968): the median of the pairwise slopes, robust to a wrong visit; its
    confidence interval from Kendall's τ (Sen 1968 eq. 2.6, as :func:`scipy.stats.theilslopes`
    computes it; :func:`theil_sen` gives the same numbers without the n × n difference
    matrices and the full sort of the slopes: the few order statistics it needs are found
    by partial partition, O(n²) instead of O(n² log n)).  With few
    points that happen to line up, that rank interval can be narrower than the stated
    uncertainties of the points allow, so when every point has ``u > 0`` the interval is
    widened to cover also ``slope ± z·σ_b``, where ``σ_b = 1/√Σ wᵢ(tᵢ − t̄_w)²``
    (``wᵢ = 1/uᵢ²``) is the standard error of a weighted least-squares slope due to the
    stated uncertainties alone.  The line passes through the *pivot* (median time,
    median value), as scipy's "separate" intercept does.

Time left (:func:`forecast_threshold`)
    The fitted line and the lines through the pivot with the slope's interval bounds give
    the crossing time and its interval: the steepest worsening slope gives the earliest
    crossing, the shallowest the latest (infinite when the interval reaches "not
    worsening").  Never an exception for a short or improving series: the result's
    ``status`` says which case applies —

    ``"worsening"``          slope worsening: ``time_left`` finite, interval given;
    ``"not_worsening"``      slope ≤ 0 in the worsening direction: ``time_left = inf``;
                             ``time_left_low`` is still the earliest crossing the slope
                             interval allows (inf if none);
    ``"crossed"``            the fitted value at ``now`` is already past the threshold
                             (``crossed_at``: when the fitted line crossed it);
    ``"insufficient_data"``  fewer than :data:`MIN_POINTS` distinct times.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy import stats

from diagnostics.uncertainty import Estimate
from sim.errors import InputError
from sim.units import unit_suffix

__all__ = [
    "DAY_S",
    "EXACT_PAIRS",
    "MIN_POINTS",
    "SAMPLED_PAIRS",
    "ThresholdForecast",
    "TrendFit",
    "TrendSeries",
    "fit_trend",
    "forecast_threshold",
    "span",
    "theil_sen",
]

#: Fewest distinct visit times for a trend (two points give a slope but no interval).
MIN_POINTS = 3

Direction = Literal["increasing", "decreasing"]
Status = Literal["worsening", "not_worsening", "crossed", "insufficient_data"]


@dataclass(frozen=True, slots=True)
class TrendSeries:
    """History of one parameter of one component of one rig.

    Parameters
    ----------
    rig_id, component, quantity, unit
        What the series is (``"rig-7"``, ``"cylinder"``, ``"cc"``, ``"m"``).
    times
        Visit times [s].
    values
        Estimates [unit].
    uncertainties
        Standard uncertainties of the estimates [unit], or ``None``.
    """

    rig_id: str
    component: str
    quantity: str
    unit: str
    times: tuple[float, ...]
    values: tuple[float, ...]
    uncertainties: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if len(self.times) != len(self.values):
            raise InputError("times and values differ in length", field="values")
        if self.uncertainties is not None and len(self.uncertainties) != len(self.values):
            raise InputError("uncertainties and values differ in length", field="uncertainties")
        for name in ("times", "values", "uncertainties"):
            seq = getattr(self, name)
            for i, x in enumerate(seq or ()):
                if not math.isfinite(x) or (name == "uncertainties" and x < 0.0):
                    raise InputError(f"invalid entry {x}", field=f"{name}[{i}]")

    @classmethod
    def from_estimates(cls, rig_id: str, component: str, times: Sequence[float],
                       estimates: Sequence[Estimate]) -> TrendSeries:
        """Series from inversion results (their ``value``, ``u``, ``quantity`` and ``unit``)."""
        if not estimates:
            raise InputError("no estimates", field="estimates")
        first = estimates[0]
        for i, e in enumerate(estimates):
            if (e.quantity, e.unit) != (first.quantity, first.unit):
                raise InputError("estimates of different quantities", field=f"estimates[{i}]")
        return cls(rig_id, component, first.quantity, first.unit, tuple(map(float, times)),
                   tuple(e.value for e in estimates), tuple(e.u for e in estimates))

    @property
    def n_distinct(self) -> int:
        """Number of distinct visit times."""
        return len(set(self.times))


@dataclass(frozen=True, slots=True)
class TrendFit:
    """Robust straight line through a series.

    Attributes
    ----------
    slope, slope_low, slope_high
        Theil–Sen slope and its interval [unit/s] (widened by the stated uncertainties,
        module docstring).
    rank_low, rank_high
        Theil–Sen interval from the ranks alone [unit/s].
    slope_u_measurement
        Standard error of the slope implied by the stated uncertainties [unit/s] (nan
        when not every point has ``u > 0``).
    pivot_time, pivot_value
        Median time [s] and median value [unit]; the line passes through them.
    confidence
        Confidence level of the intervals [-].
    n
        Number of points.
    """

    slope: float
    slope_low: float
    slope_high: float
    rank_low: float
    rank_high: float
    slope_u_measurement: float
    pivot_time: float
    pivot_value: float
    confidence: float
    n: int

    def value_at(self, t: float, slope: float | None = None) -> float:
        """Fitted value [unit] at time ``t`` [s] (with another slope through the pivot)."""
        s = self.slope if slope is None else slope
        return self.pivot_value + s * (t - self.pivot_time)


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
    and y), computed from the pairs of the time-sorted series and a partial partition.

    Raises
    ------
    InputError
        Fewer than two distinct times.
    """
    tt = np.asarray(t, dtype=np.float64).ravel()
    yy = np.asarray(y, dtype=np.float64).ravel()
    order = np.argsort(tt, kind="stable")
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


def fit_trend(series: TrendSeries, *, confidence: float = 0.95) -> TrendFit:
    """Theil–Sen slope with its confidence interval (module docstring).

    Raises
    ------
    InputError
        Fewer than :data:`MIN_POINTS` distinct times, or a confidence outside (0, 1).
    """
    if not (0.0 < confidence < 1.0):
        raise InputError("confidence must lie in (0, 1)", field="confidence")
    if series.n_distinct < MIN_POINTS:
        raise InputError(f"a trend needs {MIN_POINTS} distinct visit times, got "
                         f"{series.n_distinct}", field="times")
    t = np.asarray(series.times, dtype=np.float64)
    y = np.asarray(series.values, dtype=np.float64)
    slope, rank_low, rank_high = theil_sen(t, y, confidence=confidence)
    low, high = rank_low, rank_high
    u_meas = math.nan
    if series.uncertainties is not None and min(series.uncertainties) > 0.0:
        w = 1.0 / np.asarray(series.uncertainties, dtype=np.float64) ** 2
        t_bar = float(np.sum(w * t) / np.sum(w))
        u_meas = 1.0 / math.sqrt(float(np.sum(w * (t - t_bar) ** 2)))
        z = float(stats.norm.ppf(0.5 + confidence / 2.0))
        low, high = min(low, slope - z * u_meas), max(high, slope + z * u_meas)
    return TrendFit(slope, low, high, rank_low, rank_high, u_meas,
                    float(np.median(t)), float(np.median(y)), confidence, len(t))


@dataclass(frozen=True, slots=True)
class ThresholdForecast:
    """When a parameter will cross a threshold.

    Attributes
    ----------
    status
        ``"worsening"``, ``"not_worsening"``, ``"crossed"`` or ``"insufficient_data"``
        (module docstring).
    threshold
        The threshold [unit].
    direction
        ``"increasing"`` if larger values are worse (clearances, Cs), else
        ``"decreasing"``.
    now
        Reference time [s] (default: the last visit).
    time_left
        Time from ``now`` to the crossing on the fitted line [s] (inf if never; 0 if
        crossed; nan if insufficient data).
    time_left_low, time_left_high
        Earliest and latest crossing the slope interval allows, from ``now`` [s].
    fit
        The trend, or ``None`` with insufficient data.
    message
        One sentence for the report.
    crossed_at
        ``"crossed"``: when the fitted line crossed the threshold [s, the series' time
        origin]; NaN otherwise, or when the line does not worsen (a level already past
        the threshold).
    """

    status: Status
    threshold: float
    direction: Direction
    now: float
    time_left: float
    time_left_low: float
    time_left_high: float
    fit: TrendFit | None
    message: str
    crossed_at: float = math.nan


def _time_to(fit: TrendFit, threshold: float, slope: float, now: float) -> float:
    """Time from ``now`` until the line through the pivot with ``slope`` reaches it [s]."""
    if slope <= 0.0:
        return math.inf
    return max(fit.pivot_time + (threshold - fit.pivot_value) / slope - now, 0.0)


#: a day [s]: the unit of the trends' rates and spans
DAY_S = 86400.0


def span(seconds: float) -> str:
    """A time span as an operator reads it: days from a day up, hours from an hour, else
    seconds (the trend table's rates are per day; messages once gave 1.83e+06 s)."""
    if not math.isfinite(seconds):
        return "never" if seconds > 0 else f"{seconds:g} s"
    if abs(seconds) >= DAY_S:
        return f"{seconds / DAY_S:.3g} days"
    if abs(seconds) >= 3600.0:
        return f"{seconds / 3600.0:.3g} h"
    return f"{seconds:.3g} s"


def forecast_threshold(series: TrendSeries, threshold: float, *,
                       direction: Direction = "increasing", now: float | None = None,
                       confidence: float = 0.95) -> ThresholdForecast:
    """Time left until ``threshold`` is crossed, with its interval (module docstring).

    Parameters
    ----------
    series
        The history.
    threshold
        Limit of the parameter [unit] (e.g. a clearance at which the rig is too slow).
    direction
        Whether larger (``"increasing"``) or smaller values are worse.
    now
        Reference time [s]; default the last visit.
    confidence
        Confidence level of the slope interval [-].
    """
    if direction not in ("increasing", "decreasing"):
        raise InputError(f"unknown direction {direction!r}", field="direction")
    if not math.isfinite(threshold):
        raise InputError("threshold must be finite", field="threshold")
    t_ref = max(series.times, default=math.nan) if now is None else float(now)
    if series.n_distinct < MIN_POINTS:
        return ThresholdForecast(
            "insufficient_data", threshold, direction, t_ref, math.nan, math.nan, math.nan,
            None, f"{series.n_distinct} distinct visit(s): a trend needs {MIN_POINTS}")
    fit = fit_trend(series, confidence=confidence)
    d = 1.0 if direction == "increasing" else -1.0
    # work in the "worse = larger" frame: values, threshold and slopes times d
    lo, hi = sorted((d * fit.slope_low, d * fit.slope_high))
    rank_lo, rank_hi = sorted((d * fit.rank_low, d * fit.rank_high))
    f = TrendFit(d * fit.slope, lo, hi, rank_lo, rank_hi, fit.slope_u_measurement,
                 fit.pivot_time, d * fit.pivot_value, confidence, fit.n)
    thr = d * threshold
    earliest = _time_to(f, thr, f.slope_high, t_ref)
    latest = _time_to(f, thr, f.slope_low, t_ref)
    # " m" after a number; nothing for a dimensionless quantity ("1.1e-07 1" read as a typo)
    unit = unit_suffix(series.unit)
    per_day = f"{series.unit}/day" if unit else "per day"
    if f.value_at(t_ref) >= thr:
        # when the fitted line crossed: before the reference time, or (a level already
        # past the threshold that does not rise) not on this line
        crossed = f.pivot_time + (thr - f.pivot_value) / f.slope if f.slope > 0.0 \
            else math.nan
        when = (f"; the fitted line crossed it {span(t_ref - crossed)} before the reference "
                "time" if math.isfinite(crossed) else "")
        return ThresholdForecast("crossed", threshold, direction, t_ref, 0.0, 0.0, 0.0, fit,
                                 f"{series.quantity} is past {threshold:.4g}{unit} on the "
                                 f"fitted trend{when}", crossed)
    if f.slope <= 0.0:
        if math.isnan(earliest):
            # no rank interval: the estimates are (nearly) all equal, Sen's variance of
            # their ties is not positive; "could already be past" was said of values 37 %
            # below the threshold (a fleet integrator's pass)
            steepest = "the data give the slope no interval (their values are tied)"
        elif math.isinf(earliest):
            steepest = f"not even the steepest slope the data allow reaches {threshold:.4g}{unit}"
        elif earliest > 0.0:
            steepest = (f"at the steepest slope the data allow, {threshold:.4g}{unit} would "
                        f"be reached in {span(earliest)}")
        else:
            steepest = (f"at the steepest slope the data allow it could already be past "
                        f"{threshold:.4g}{unit}")
        return ThresholdForecast("not_worsening", threshold, direction, t_ref, math.inf,
                                 earliest, math.inf, fit,
                                 f"{series.quantity} is not worsening (slope "
                                 f"{fit.slope * DAY_S:.3g} {per_day}); {steepest}")
    left = _time_to(f, thr, f.slope, t_ref)
    return ThresholdForecast("worsening", threshold, direction, t_ref, left, earliest, latest,
                             fit, f"{series.quantity} reaches {threshold:.4g}{unit} in "
                             f"{span(left)} ({100 * confidence:.0f} % interval "
                             f"{span(earliest)} to {span(latest)})")
