"""Is one held-out model better than another?  A paired block bootstrap over speed levels.

:func:`~diagnostics.pump.piston.held_out_speed` scores a loss model and a plain quadratic on
the same split (one speed left out at a time) by S, the rms held-out error [% of the
setting's largest value].  Their difference is a statistic of a few speed levels: the
errors inside one held-out speed are correlated (the whole speed is extrapolated at once),
so the uncertainty of ``S_model − S_quadratic`` is taken by resampling *whole speed
levels* with replacement, both models' errors together (paired), and recomputing both S
(Efron & Tibshirani, *An Introduction to the Bootstrap*, 1993, block resampling; not a
seed paper).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.pump.levels import cluster_levels
from sim.errors import InputError

__all__ = ["SDifference", "s_difference"]


@dataclass(frozen=True, slots=True)
class SDifference:
    """``S_a − S_b`` [% of ``full``] and its bootstrap interval (``level``, two-sided)."""

    difference: float
    low: float
    high: float
    level: float
    blocks: int


def s_difference(y: npt.ArrayLike, pred_a: npt.ArrayLike, pred_b: npt.ArrayLike,
                 speed: npt.ArrayLike, full: float, *, reps: int = 2000, level: float = 0.95,
                 seed: int = 0) -> SDifference:
    """``S_a − S_b`` [%] of two held-out predictions and its paired block-bootstrap interval.

    Parameters
    ----------
    y, pred_a, pred_b
        Measured values and the two models' held-out predictions [any one unit].
    speed
        Speed of each point [rad/s]; its levels are the resampled blocks.
    full
        Scale of S [the unit of ``y``] (the setting's largest value).

    Raises
    ------
    InputError
        Lengths differ, fewer than 2 speed levels, ``full`` ≤ 0, or ``level`` outside (0, 1).
    """
    yy, a, b = (np.asarray(x, dtype=np.float64) for x in (y, pred_a, pred_b))
    if not (yy.shape == a.shape == b.shape == np.shape(speed)):
        raise InputError("measurements, predictions and speeds differ in length", field="y")
    if not (full > 0 and 0 < level < 1):
        raise InputError("full must be > 0 and level in (0, 1)", field="full")
    idx, lev = cluster_levels(np.asarray(speed, dtype=np.float64), field="Speed")
    if lev.size < 2:
        raise InputError("the bootstrap needs at least 2 speed levels", field="Speed")
    ea, eb = (yy - a) ** 2, (yy - b) ** 2
    sums = np.array([[ea[idx == k].sum(), eb[idx == k].sum(), (idx == k).sum()]
                     for k in range(lev.size)])

    def diff(rows: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        n = rows[..., 2]
        return np.asarray(100.0 / full * (np.sqrt(rows[..., 0] / n) - np.sqrt(rows[..., 1] / n)),
                          dtype=np.float64)

    rng = np.random.default_rng(seed)
    pick = rng.integers(0, lev.size, size=(reps, lev.size))
    boot = diff(sums[pick].sum(axis=1))
    tail = 0.5 * (1.0 - level)
    lo, hi = np.quantile(boot, [tail, 1.0 - tail])
    d = float(diff(sums.sum(axis=0)))
    if not math.isfinite(d):
        raise InputError("no finite errors to compare", field="y")
    return SDifference(d, float(lo), float(hi), level, int(lev.size))
