"""Trends of a diagnosed parameter over visits, and the time left to a threshold.

A :class:`TrendSeries` is one rig's history of one component's parameter (``cc``, ``cv``,
``Cs``): times [s] (any common origin, e.g. Unix time), estimates and their standard
uncertainties; it and its slope (:func:`fit_trend`: Theil–Sen with a rank interval
widened by the stated uncertainties) are :mod:`diagnostics.trend_fit`'s, exported here too.

Time left (:func:`forecast_threshold`)
    The fitted line gives the crossing time; its interval joins two parts in quadrature:
    the lines with the slope's interval bounds (each with its own joint intercept: the
    steepest worsening slope gives the earliest crossing, the shallowest the latest,
    infinite when the interval reaches "not worsening") and the level's uncertainty
    (±1.96 u_level / slope).  On simulated straight-line wear (10-400 visits, Gaussian
    scatter) this interval holds the true crossing in 95-97.5 % of campaigns, where the
    lines through the median value's pivot held it in 63-91 % (``make trend-study``).
    Never an exception for a short or improving series: the result's ``status`` says
    which case applies —

    ``"worsening"``          the whole slope interval worsening: ``time_left`` finite,
                             interval given;
    ``"not_worsening"``      the slope interval reaches 0 in the worsening direction (a
                             healthy component's scatter read "worsening" 8 times in 20
                             by the slope's sign alone, a planner's pass):
                             ``time_left = inf``; ``time_left_low`` is still the earliest
                             crossing the interval allows (inf if none);
    ``"crossed"``            the fitted value at ``now`` is already past the threshold
                             (``crossed_at``: when the fitted line crossed it);
    ``"insufficient_data"``  fewer than :data:`MIN_POINTS` distinct times.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from scipy import stats

from diagnostics.level_shift import MIN_SIDE, LevelShift
from diagnostics.robust import mad_sigma
from diagnostics.theil_sen import EXACT_PAIRS, SAMPLED_PAIRS, theil_sen
from diagnostics.trend_fit import MIN_POINTS, TrendFit, TrendSeries, fit_trend, latest_step
from sim.errors import InputError
from sim.units import quantity_text, unit_suffix

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

Direction = Literal["increasing", "decreasing"]
Status = Literal["worsening", "not_worsening", "crossed", "insufficient_data"]


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
    step
        The latest step in the level (:func:`diagnostics.level_shift.level_shift`), or
        None; with one, the trend and the forecast use the visits after it.
    n_used
        Visits the trend was fitted to [-].
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
    step: LevelShift | None = None
    n_used: int = 0


def _time_to(fit: TrendFit, threshold: float, slope: float, level: float, now: float
             ) -> float:
    """Time from ``now`` until the line with ``slope`` and ``level`` at the pivot time
    reaches ``threshold`` [s]: negative when it did before ``now``, inf when it never does."""
    if slope <= 0.0:
        return math.inf
    return fit.pivot_time + (threshold - level) / slope - now


def _crossing_interval(f: TrendFit, thr: float, now: float, z: float) -> tuple[float, float]:
    """Earliest and latest crossing from ``now`` [s] (module docstring), in the frame where
    worse is larger; never negative."""
    hi, lo = f.slope_high, f.slope_low
    if not (f.slope > 0.0 and lo > 0.0):
        # not worsening: the earliest crossing of the steepest line with its level raised;
        # the quadrature about the central line divided the level's uncertainty by a slope
        # near zero (a flat history's 1e-25) and read "could already be past" (a check)
        early = _time_to(f, thr, hi, f.level_high, now) - (z * f.level_u / hi if hi > 0 else 0)
        return max(early, 0.0), math.inf
    central = _time_to(f, thr, f.slope, f.pivot_value, now)
    level = z * f.level_u / f.slope
    early = central - math.hypot(central - _time_to(f, thr, hi, f.level_high, now), level)
    late = (central + math.hypot(_time_to(f, thr, lo, f.level_low, now) - central, level)
            if lo > 0.0 else math.inf)
    return max(early, 0.0), max(late, 0.0)


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
                       confidence: float = 0.95, steps: bool = True,
                       when: Callable[[float], str] | None = None) -> ThresholdForecast:
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
    steps
        Whether to look for a step in the level first (:func:`latest_step`) and forecast
        from the visits after it.
    when
        How the message says a time of the series [s] (the service: a date); default how
        long before the reference time.
    """
    if direction not in ("increasing", "decreasing"):
        raise InputError(f"unknown direction {direction!r}", field="direction")
    if not math.isfinite(threshold):
        raise InputError("threshold must be finite", field="threshold")
    t_ref = max(series.times, default=math.nan) if now is None else float(now)
    fit = fit_trend(series, confidence=confidence) if series.n_distinct >= MIN_POINTS \
        else None
    step = latest_step(series, fit.slope) if steps and fit is not None else None
    if step is None:
        out = _forecast(series, threshold, direction, t_ref, confidence, fit)
        return replace(out, n_used=len(series.times),
                       message=out.message + _off_line(series, out.fit, when, t_ref))
    used = series.after(step.time)
    out = _forecast(used, threshold, direction, t_ref, confidence)
    sign = "+" if step.size > 0 else ""
    at = when(step.time) if when is not None else \
        f"{span(t_ref - step.time)} before the reference time"
    note = (f"a step of {sign}{quantity_text(step.size, series.unit, 3)} in "
            f"{series.quantity} {at} (a contamination event, a part changed, or wear that "
            f"sped up): the trend uses the {len(used.times)} visit(s) after it; ")
    return replace(out, step=step, n_used=len(used.times),
                   message=note + out.message + _off_line(used, out.fit, when, t_ref))


#: how far off the fitted line the latest visits must each be to be said [σ]
OFF_LINE = 3.0


def _off_line(series: TrendSeries, fit: TrendFit | None,
              when: Callable[[float], str] | None, t_ref: float) -> str:
    """A note when the latest visits, fewer than a step needs (:data:`MIN_SIDE`), all sit
    more than :data:`OFF_LINE` σ on one side of the fitted line (σ: each visit's stated
    uncertainty or the line's robust scatter, the larger): three visits after a new seal
    read 35 µm below a line still forecasting the old seal's "57 days to the threshold"
    without a word (a reliability engineer's pass); the step test names it from the
    fourth visit on."""
    if fit is None or series.uncertainties is None:
        # without each visit's stated uncertainty an estimate at its bound (0 µm, its
        # interval holding the line) read as "sits 36 µm below" (a verification pass)
        return ""
    order = np.argsort(np.asarray(series.times, dtype=np.float64), kind="stable")
    t = np.asarray(series.times, dtype=np.float64)[order]
    r = np.asarray(series.values, dtype=np.float64)[order] - (
        fit.pivot_value + fit.slope * (t - fit.pivot_time))
    u = np.asarray(series.uncertainties, dtype=np.float64)[order]
    sigma = np.maximum(u, mad_sigma(r))
    beyond = np.sign(r) * (np.abs(r) > OFF_LINE * sigma)
    count = 0
    while count < min(MIN_SIDE - 1, t.size - MIN_POINTS) and beyond[-1 - count] != 0 and \
            beyond[-1 - count] == beyond[-1]:
        count += 1
    if not count or not np.all(sigma[-count:] > 0):
        return ""
    first = float(t[-count])
    at = when(first) if when is not None else f"{span(t_ref - first)} before the reference time"
    offset = float(np.mean(r[-count:]))
    side = "below" if offset < 0 else "above"
    return (f"; the latest {count} visit(s), from {at} on, sit "
            f"{quantity_text(abs(offset), series.unit, 3)} {side} the fitted line (each "
            f"beyond {OFF_LINE:g} σ): a part changed or an event, which the step test "
            f"confirms once {MIN_SIDE} visits follow it; a part changed on a known date: "
            "read the trend from that date on (since)")


def _forecast(series: TrendSeries, threshold: float, direction: Direction, t_ref: float,
              confidence: float, fit: TrendFit | None = None) -> ThresholdForecast:
    """:func:`forecast_threshold` of ``series`` as it is (no step looked for); ``fit``:
    its trend when already made."""
    if series.n_distinct < MIN_POINTS:
        return ThresholdForecast(
            "insufficient_data", threshold, direction, t_ref, math.nan, math.nan, math.nan,
            None, f"{series.n_distinct} distinct visit(s): a trend needs {MIN_POINTS}")
    fit = fit if fit is not None else fit_trend(series, confidence=confidence)
    d = 1.0 if direction == "increasing" else -1.0
    # work in the "worse = larger" frame: values, threshold and slopes times d (the bound
    # slopes swap places with their levels)
    (lo, level_lo), (hi, level_hi) = sorted(((d * fit.slope_low, d * fit.level_low),
                                             (d * fit.slope_high, d * fit.level_high)))
    rank_lo, rank_hi = sorted((d * fit.rank_low, d * fit.rank_high))
    f = TrendFit(d * fit.slope, lo, hi, rank_lo, rank_hi, fit.slope_u_measurement,
                 fit.pivot_time, d * fit.pivot_value, confidence, fit.n, level_lo, level_hi,
                 fit.level_u)
    thr = d * threshold
    z = float(stats.norm.ppf(0.5 + confidence / 2.0))
    earliest, latest = _crossing_interval(f, thr, t_ref, z)
    limit = quantity_text(threshold, series.unit)
    rate = (quantity_text(fit.slope * DAY_S, f"{series.unit}/day", 3) if unit_suffix(series.unit)
            else f"{fit.slope * DAY_S:.3g} per day")
    if f.value_at(t_ref) >= thr:
        # when the fitted line crossed: before the reference time, or (a level already
        # past the threshold that does not rise) not on this line
        crossed = f.pivot_time + (thr - f.pivot_value) / f.slope if f.slope > 0.0 \
            else math.nan
        when = (f"; the fitted line crossed it {span(t_ref - crossed)} before the reference "
                "time" if math.isfinite(crossed) else "")
        return ThresholdForecast("crossed", threshold, direction, t_ref, 0.0, 0.0, 0.0, fit,
                                 f"{series.quantity} is past {limit} on the fitted "
                                 f"trend{when}", crossed)
    if f.slope_low <= 0.0 or not f.slope > 0.0:
        if math.isnan(earliest):
            # no rank interval: the estimates are (nearly) all equal, Sen's variance of
            # their ties is not positive; "could already be past" was said of values 37 %
            # below the threshold (a fleet integrator's pass)
            steepest = "the data give the slope no interval (their values are tied)"
        elif math.isinf(earliest):
            steepest = f"not even the steepest slope the data allow reaches {limit}"
        elif earliest > 0.0:
            # both parts named: the steepest line's own crossing was 18.9 days, its level
            # raised by its uncertainty 1.72 (a reliability engineer's pass)
            steepest = (f"at the steepest slope the data allow, and the level at the top "
                        f"of its {100 * confidence:.0f} % interval, {limit} would be "
                        f"reached in {span(earliest)}")
        else:
            steepest = (f"at the steepest slope the data allow, and the level at the top "
                        f"of its {100 * confidence:.0f} % interval, it could already be "
                        f"past {limit}")
        said = (f"{series.quantity} is not worsening (slope {rate})" if not f.slope > 0.0 else
                f"{series.quantity} shows no significant worsening (slope {rate}, its "
                f"{100 * confidence:.0f} % interval reaches zero)")
        return ThresholdForecast("not_worsening", threshold, direction, t_ref, math.inf,
                                 earliest, math.inf, fit, f"{said}; {steepest}")
    left = max(_time_to(f, thr, f.slope, f.pivot_value, t_ref), 0.0)
    return ThresholdForecast("worsening", threshold, direction, t_ref, left, earliest, latest,
                             fit, f"{series.quantity} reaches {limit} in {span(left)} "
                             f"({100 * confidence:.0f} % interval {span(earliest)} to "
                             f"{span(latest)})")
