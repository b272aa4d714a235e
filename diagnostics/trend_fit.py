"""The trend of a diagnosed parameter over visits: its series and its robust slope.

A :class:`TrendSeries` is one rig's history of one component's parameter (``cc``, ``cv``,
``Cs``): times [s] (any common origin, e.g. Unix time), estimates and their standard
uncertainties.  The time left to a threshold is :mod:`diagnostics.trends`'.

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
    stated uncertainties alone.  The line's level at the median time is the median of the
    points' residuals from the slope (Conover's joint intercept, scipy's ``"joint"``
    method): the median *value* (scipy's ``"separate"``, used before) is one reading near
    the middle of a rising series, so the level carried that reading's noise and one
    wrong record moved a forecast from 13.6 to 7.3 days while the slope hardly moved (a
    maintenance planner's pass).  The level's standard uncertainty is that of a median of
    the residuals, √(π/2)·σ/√n = 1.2533 σ/√n (the sample median's asymptotic variance
    πσ²/(2n) for normal errors, Laplace; Kendall & Stuart), with σ their robust (MAD,
    1.4826 × median |r|) scatter or the stated uncertainties, the larger.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from diagnostics.level_shift import LevelShift, level_shift
from diagnostics.robust import mad_sigma
from diagnostics.theil_sen import theil_sen
from diagnostics.uncertainty import Estimate
from sim.errors import InputError

__all__ = ["MIN_POINTS", "RESOLUTION_ULPS", "TrendFit", "TrendSeries", "fit_trend",
           "latest_step"]

#: Fewest distinct visit times for a trend (two points give a slope but no interval).
MIN_POINTS = 3
#: A slope whose change over the series' span is at most this many units in the last place
#: of its largest value is read as 0 [-] (float rounding of re-diagnosed records, not wear).
RESOLUTION_ULPS = 64


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

    def after(self, t: float) -> TrendSeries:
        """The visits after time ``t`` [s]."""
        keep = [i for i, ti in enumerate(self.times) if ti > t]
        return replace(self, times=tuple(self.times[i] for i in keep),
                       values=tuple(self.values[i] for i in keep),
                       uncertainties=None if self.uncertainties is None else
                       tuple(self.uncertainties[i] for i in keep))


def latest_step(series: TrendSeries, slope: float | None = None) -> LevelShift | None:
    """The latest step in ``series``' level: the test of
    :func:`~diagnostics.level_shift.level_shift` repeated on the visits after each step
    found (a history may hold more than one event), or None; ``slope``: the whole
    series' Theil–Sen slope [unit/s] when already known."""
    step = None
    rest = series
    while rest.n_distinct >= MIN_POINTS:
        t = np.asarray(rest.times, dtype=np.float64)
        y = np.asarray(rest.values, dtype=np.float64)
        b = slope if slope is not None and rest is series else theil_sen(t, y)[0]
        found = level_shift(t, y, b, rest.uncertainties)
        if found is None:
            break
        step, rest = found, rest.after(found.time)
    return step


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
        Median time [s] and the line's level there [unit] (the joint intercept).
    confidence
        Confidence level of the intervals [-].
    n
        Number of points.
    level_low, level_high
        Levels at ``pivot_time`` of the lines with slopes ``slope_low`` and ``slope_high``,
        each the median residual from its slope [unit].
    level_u
        Standard uncertainty of ``pivot_value`` [unit].
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
    level_low: float = math.nan
    level_high: float = math.nan
    level_u: float = 0.0

    def value_at(self, t: float) -> float:
        """Fitted value [unit] at time ``t`` [s]."""
        return self.pivot_value + self.slope * (t - self.pivot_time)


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
    # a change over the whole span below the values' float resolution is no slope: the
    # same record diagnosed again reads the last bit differently, and a trend of such
    # visits showed "6e-15 µm/day" (a CLI pass)
    resolution = RESOLUTION_ULPS * np.finfo(np.float64).eps * float(np.max(np.abs(y)))
    span = float(t.max() - t.min())
    slope, rank_low, rank_high = (0.0 if abs(b) * span <= resolution else b
                                  for b in (slope, rank_low, rank_high))
    low, high = rank_low, rank_high
    u_meas = math.nan
    # the level's scatter: the residuals' robust σ, or the stated uncertainties
    t_p = float(np.median(t))
    dt = t - t_p
    level = float(np.median(y - slope * dt))
    sigma = mad_sigma(y - slope * dt)
    if series.uncertainties is not None and min(series.uncertainties) > 0.0:
        w = 1.0 / np.asarray(series.uncertainties, dtype=np.float64) ** 2
        t_bar = float(np.sum(w * t) / np.sum(w))
        u_meas = 1.0 / math.sqrt(float(np.sum(w * (t - t_bar) ** 2)))
        z = float(stats.norm.ppf(0.5 + confidence / 2.0))
        low, high = min(low, slope - z * u_meas), max(high, slope + z * u_meas)
        sigma = max(sigma, math.sqrt(len(t) / float(np.sum(w))))
    return TrendFit(slope, low, high, rank_low, rank_high, u_meas, t_p, level, confidence,
                    len(t), float(np.median(y - low * dt)), float(np.median(y - high * dt)),
                    1.2533 * sigma / math.sqrt(len(t)))
