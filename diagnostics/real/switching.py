"""Valve switching time of a load cycle from the pressure step it causes, at any sample rate.

When the directional valve of a constant load cycle switches, the pump pressure falls from
one steady level ``p_hi`` (here the relief setting) to another ``p_lo`` (the working load).
The *equivalent step time* ``t*`` is the time of the ideal step with the same pressure
integral over the transition window ``[t_a, t_b)``::

    t* = t_a + Σ_k (p_k − p_lo)/(p_hi − p_lo) · Δt          [s]

(the first moment of the normalised step response: for an ideal step at ``t_s`` it is
``t_s``, for a finite ramp its centre).  The sum needs only the *integral* of the pressure
over each sample interval, so block means give the same ``t*`` as the raw samples: the
1-second means of the ZeMA files (1 Hz) and the raw 100 Hz samples of the same cycle give
the same value, which is what lets the switching lag be read for all 2205 cycles although
the raw 100 Hz data exist for only ten.

The command time of the cycle program is not recorded, but it is the same in every cycle,
so the *lag* is ``t*`` less a campaign reference taken without labels (a low quantile of
``t*``: the fastest switching seen) — :func:`switching_lags`.  Helwig et al. (I2MTC 2015)
degrade the valve by delaying its switching (valve condition 100/90/80/73 %); a slower
valve gives a later ``t*``.

At the native rate the response can also be timed where it starts: :func:`crossing_time`
gives the first crossing of a level (the working pressure PS2 behind the valve rising
through 5 bar: the valve opening; the pump pressure's 90 % and 10 % points: its fall).
At 1 Hz a crossing is only known to the second, so only ``t*`` serves there.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from diagnostics.sampling import uniform_rate
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError, MeasurementError

__all__ = ["crossing_time", "step_time", "switching_lags", "switching_times"]

Arr = npt.NDArray[np.float64]


def _select(record: SeriesRecord, window: tuple[float, float], what: str) -> npt.NDArray[np.bool_]:
    t = record.t - record.t[0]
    a, b = window
    if not b > a:
        raise InputError(f"{what} window must have stop > start, got {window}", field=what)
    sel = (t >= a - 1e-9) & (t < b - 1e-9)
    if not sel.any():
        raise MeasurementError(f"record {record.name!r} has no sample in the {what} window "
                               f"[{a:g}, {b:g}) s", field=what)
    return sel


def step_time(record: SeriesRecord, *, channel: str = "p_pump",
              before: tuple[float, float] = (2.0, 9.0),
              during: tuple[float, float] = (9.0, 11.0),
              after: tuple[float, float] = (12.0, 19.0), min_step: float = 1.0e5) -> float:
    """Equivalent step time ``t*`` [s from the record's start] of one pressure step.

    Parameters
    ----------
    record
        A uniformly sampled record; sample k stands for ``[t_k, t_k + Δt)`` (a block mean
        or a held raw sample).
    channel
        Pressure channel [Pa].
    before, after
        Windows ``[start, stop)`` [s] of the steady levels before and after the step.
    during
        Window ``[t_a, t_b)`` [s] holding the whole transition.
    min_step
        Smallest ``|p_hi − p_lo|`` [Pa] accepted as a step.

    Raises
    ------
    InputError
        Not uniformly sampled, or a window with stop ≤ start.
    MeasurementError
        A window without samples, or no step of at least ``min_step``
        (``field=channel``).
    """
    rate = uniform_rate(record)
    p = record.channel(channel)
    sel = _select(record, during, "during")
    hi = float(p[_select(record, before, "before")].mean())
    lo = float(p[_select(record, after, "after")].mean())
    if abs(hi - lo) < min_step:
        raise MeasurementError(f"record {record.name!r}: no pressure step in {channel} "
                               f"({abs(hi - lo) / 1e5:.3g} bar < {min_step / 1e5:.3g} bar)",
                               field=channel)
    frac = (p[sel] - lo) / (hi - lo)
    t0 = float(record.t[sel][0] - record.t[0])
    return t0 + float(frac.sum()) / rate


def crossing_time(record: SeriesRecord, level: float, *, channel: str = "p_work",
                  during: tuple[float, float] = (9.0, 11.0), rising: bool = True) -> float:
    """First time [s from the record's start] in ``during`` at which ``channel`` crosses ``level``.

    Linear interpolation between the two samples around the crossing; ``rising`` False for a
    fall through ``level`` [channel unit].

    Raises
    ------
    MeasurementError
        No crossing inside the window, or already past ``level`` at its first sample
        (``field=channel``).
    """
    x = record.channel(channel)
    sel = np.flatnonzero(_select(record, during, "during"))
    t = record.t - record.t[0]
    above = x[sel] > level if rising else x[sel] < level
    hit = np.flatnonzero(above)
    if hit.size == 0 or hit[0] == 0:
        raise MeasurementError(f"record {record.name!r}: {channel} does not cross "
                               f"{level:g} in [{during[0]:g}, {during[1]:g}) s", field=channel)
    k = int(sel[hit[0]])
    x0, x1 = float(x[k - 1]), float(x[k])
    frac = (level - x0) / (x1 - x0) if x1 != x0 else 1.0
    return float(t[k - 1] + frac * (t[k] - t[k - 1]))


def switching_times(records: Sequence[SeriesRecord], **options: object) -> Arr:
    """:func:`step_time` [s] of every record; NaN where a record has no step."""
    out = np.full(len(records), np.nan)
    for i, r in enumerate(records):
        try:
            out[i] = step_time(r, **options)  # type: ignore[arg-type]
        except MeasurementError:
            continue
    return out


def switching_lags(times: npt.ArrayLike, *, quantile: float = 0.01) -> Arr:
    """Lag [s] of every switching time behind the campaign's fast reference (no labels).

    The reference is the ``quantile`` of the finite times: the fastest switching seen, so
    one stray early cycle does not set it.

    Raises
    ------
    InputError
        No finite time, or ``quantile`` outside [0, 1).
    """
    t = np.asarray(times, dtype=np.float64)
    if not 0.0 <= quantile < 1.0:
        raise InputError(f"quantile must lie in [0, 1), got {quantile}", field="quantile")
    ok = np.isfinite(t)
    if not ok.any():
        raise InputError("no finite switching time", field="times")
    return np.asarray(t - float(np.quantile(t[ok], quantile)), dtype=np.float64)
