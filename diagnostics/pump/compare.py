"""Is one held-out model better than another?  A paired block bootstrap over speed levels.

:func:`~diagnostics.pump.piston.held_out_speed` scores a loss model and a plain quadratic on
the same split (one speed left out at a time) by S, the rms held-out error [% of the
setting's largest value].  Their difference is a statistic of a few speed levels: the
errors inside one held-out speed are correlated (the whole speed is extrapolated at once),
so the uncertainty of ``S_model − S_quadratic`` is taken by resampling *whole speed
levels* with replacement, both models' errors together (paired), and recomputing both S
(Efron & Tibshirani, *An Introduction to the Bootstrap*, 1993, block resampling; not a
seed paper).

Why a quadratic can win: the plain quadratic in (Δp, n) is itself a member of the piston
loss families of :mod:`~diagnostics.pump.piston` — its six columns 1, Δp, ω, Δp², Δp·ω, ω²
are family terms (``D·ω`` and ``D·Δp`` fold into the ω and Δp terms) — whenever its
sign-constrained coefficients come out physical (:func:`quadratic_in_family`).  The family
then differs from it only by the subset AIC chooses in each fold; :func:`fold_s` gives the
held-out S speed by speed to see which folds carry the difference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.pump.levels import cluster_levels
from diagnostics.pump.piston import FLOW_LOSS_TERMS, TORQUE_LOSS_TERMS, LossTerm, PistonMap
from sim.errors import InputError

__all__ = ["QUADRATIC_TERMS", "QuadraticMembership", "SDifference", "fold_s",
           "quadratic_in_family", "s_difference"]

#: The family terms that span the plain quadratic in (Δp, ω), flow and torque alike.
QUADRATIC_TERMS = frozenset({"1", "dp", "omega", "dp^2", "dp*omega", "omega^2"})


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


@dataclass(frozen=True)
class QuadraticMembership:
    """The quadratic's loss coefficients on a setting and whether their signs are physical.

    Attributes
    ----------
    flow_coef, torque_coef
        Coefficient per family term [SI] of ``D·ω − q`` and ``T − D·Δp`` fitted with the
        quadratic's six columns on all the setting's points.
    flow_member, torque_member
        Every sign-constrained coefficient has its family sign: the quadratic is one of the
        family's candidate models [-].
    """

    flow_coef: dict[str, float]
    torque_coef: dict[str, float]
    flow_member: bool
    torque_member: bool


def _fit_terms(terms: tuple[LossTerm, ...], dp: npt.NDArray[np.float64],
               w: npt.NDArray[np.float64], y: npt.NDArray[np.float64]
               ) -> tuple[dict[str, float], bool]:
    x = np.column_stack([t.column(dp, w) for t in terms])
    scale = np.max(np.abs(x), axis=0)
    scale[scale == 0] = 1.0
    c = np.linalg.lstsq(x / scale, y, rcond=None)[0] / scale
    ok = all(t.sign == 0 or v >= 0 for t, v in zip(terms, c, strict=True))
    return {t.name: float(v) for t, v in zip(terms, c, strict=True)}, bool(ok)


def quadratic_in_family(data: PistonMap, D: float) -> QuadraticMembership:
    """Fit the quadratic as a loss model of the setting ``D`` [m³/rad]; check its signs.

    Raises
    ------
    InputError
        Fewer than 6 points (``field="data"``).
    """
    if len(data) < 6:
        raise InputError("the quadratic needs at least 6 points", field="data")
    fq = tuple(t for t in FLOW_LOSS_TERMS if t.name in QUADRATIC_TERMS)
    tq = tuple(t for t in TORQUE_LOSS_TERMS if t.name in QUADRATIC_TERMS)
    fc, fok = _fit_terms(fq, data.dp, data.omega, D * data.omega - data.q)
    tc, tok = _fit_terms(tq, data.dp, data.omega, data.torque - D * data.dp)
    return QuadraticMembership(fc, tc, fok, tok)


def fold_s(y: npt.ArrayLike, pred_a: npt.ArrayLike, pred_b: npt.ArrayLike,
           speed: npt.ArrayLike, full: float) -> tuple[npt.NDArray[np.float64],
                                                       npt.NDArray[np.float64]]:
    """Held-out S [% of ``full``] of two predictions at each speed level, slowest first.

    Raises
    ------
    InputError
        Lengths differ or ``full`` ≤ 0.
    """
    yy, a, b = (np.asarray(x, dtype=np.float64) for x in (y, pred_a, pred_b))
    if not (yy.shape == a.shape == b.shape == np.shape(speed)) or not full > 0:
        raise InputError("measurements, predictions and speeds differ in length, or "
                         "full ≤ 0", field="y")
    idx, lev = cluster_levels(np.asarray(speed, dtype=np.float64), field="Speed")
    sa = np.array([math.sqrt(float(np.mean((yy - a)[idx == k] ** 2))) for k in range(lev.size)])
    sb = np.array([math.sqrt(float(np.mean((yy - b)[idx == k] ** 2))) for k in range(lev.size)])
    return 100.0 * sa / full, 100.0 * sb / full
