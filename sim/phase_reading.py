"""How a rig's meters read one phase of its cycle (paper 002 §3): which samples, which average.

Paper 002's meters are read while the piston moves steadily: the start-up transient
(pressure build-up, flow reversal in the hoses) and the arrival at the end stop are left
out, as a reader of the paper's traces does.  hydrodiag reads a moving stroke over the
middle of its travel, :data:`STEADY_TRAVEL` (10-90 %), and a stroke that does not reach
its end (the piston stalls on a load it cannot push, or creeps) over the last
:data:`SETTLED_SHARE` of the phase, the settled state a meter shows.  Averages are time
averages by the trapezoid rule, so that an uneven sampling (a solver's steps) weighs each
sample by the time it stands for.

One definition for every reader: the simulator's phase summaries (:mod:`sim.cycle`), the
readings of a measured cycle (:mod:`diagnostics.cycle_readings`) and the accuracy study's
stalled strokes (``benchmarks/accuracy_cases.py``).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["SETTLED_SHARE", "STEADY_TRAVEL", "settled_window", "steady_slope", "steady_window",
           "time_average"]

Arr = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: share of the travel over which a moving stroke is read: from 10 % to 90 % [-]
STEADY_TRAVEL = (0.1, 0.9)
#: share of a stalled or creeping phase, at its end, over which it is read [-]
SETTLED_SHARE = 0.5


def steady_window(x: Arr) -> Mask:
    """Samples of a stroke between :data:`STEADY_TRAVEL` of its travel (positions ``x``
    [m]); every sample when the piston travelled too little to have a middle (fewer than
    three samples in it)."""
    travel = np.abs(x - x[0])
    total = travel[-1]
    lo, hi = STEADY_TRAVEL
    sel: Mask = (travel >= lo * total) & (travel <= hi * total)
    if total <= 0 or sel.sum() < 3:
        sel = np.ones(x.size, dtype=bool)
    return sel


def settled_window(t: Arr) -> Mask:
    """Samples in the last :data:`SETTLED_SHARE` of a phase (times ``t`` [s]); every
    sample when fewer than two fall there."""
    sel: Mask = t >= t[0] + (1.0 - SETTLED_SHARE) * (t[-1] - t[0])
    if sel.sum() < 2:
        sel = np.ones(t.size, dtype=bool)
    return sel


def time_average(values: Arr, t: Arr) -> float:
    """Time average of ``values`` over the times ``t`` [s] (trapezoid rule); the first
    value when the span is 0."""
    span = t[-1] - t[0]
    if span <= 0:
        return float(values[0])
    # the trapezoid rule as numpy's trapezoid (2.0+; trapz before) computes it, bit for bit
    return float((np.diff(t) * (values[1:] + values[:-1]) / 2.0).sum() / span)


def steady_slope(t: Arr, x: Arr) -> float:
    """Speed of a steady stroke [m/s]: the magnitude of the least-squares slope of the
    positions ``x`` [m] over the times ``t`` [s] (a linear encoder's reading; robust to
    the position's noise, unlike the end points' difference); 0 for fewer than two
    samples or no span."""
    if t.size < 2 or t[-1] <= t[0]:
        return 0.0
    tc = t - t.mean()
    return float(abs(np.dot(tc, x - x.mean()) / np.dot(tc, tc)))
