"""A pump's loss model checked against its own test points, one speed left out at a time.

What a stored pump set keeps so that anyone can judge it later: for each oil-temperature
level of a bench table (one level for a manufacturer's map), the sign-checked loss family of
:mod:`diagnostics.pump.piston` (flow loss ``q_L = D·ω − q`` [m³/s], torque loss
``T_L = T − D·Δp`` [N·m], terms chosen by AIC), fitted at the derived capacity ``D``
[m³/rad], and every test point's flow and torque predicted by the model fitted *without that
point's speed* (:func:`diagnostics.pump.piston.held_out_speed`).  The held-out error S
[% of the level's largest flow or torque] is compared with a plain quadratic in (Δp, n)
fitted on the same split.

A level with fewer than three speeds, or a table without torque, cannot be checked this way:
:func:`check_losses` says why instead of storing anything made up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.pump.data import BenchData
from diagnostics.pump.levels import cluster_levels
from diagnostics.pump.piston import HeldOut, PistonMap, held_out_speed
from sim.errors import InputError

__all__ = ["LevelCheck", "LossCheck", "check_losses"]

Arr = npt.NDArray[np.float64]

#: Readings within this many kelvin are one oil-temperature level [K].
THETA_GAP = 2.0


@dataclass(frozen=True)
class LevelCheck:
    """The check of one oil-temperature level: its mean θ [°C] and the held-out result."""

    theta: float
    held_out: HeldOut


@dataclass(frozen=True)
class LossCheck:
    """Loss models checked at every checkable temperature level of a bench table.

    Attributes
    ----------
    D
        Displacement the losses are taken from [m³/rad].
    levels
        The checked levels.
    skipped
        One sentence per level that could not be checked, and why.
    mask
        Which test points of the table belong to a checked level [-].
    q_held_out, torque_held_out
        Held-out predictions at the points of ``mask`` [m³/s], [N·m] (table order).
    flow_S, torque_S
        RMS held-out error over all checked points [% of the largest measured flow, torque].
    """

    D: float
    levels: tuple[LevelCheck, ...]
    skipped: tuple[str, ...]
    mask: npt.NDArray[np.bool_]
    q_held_out: Arr
    torque_held_out: Arr
    flow_S: float
    torque_S: float


def check_losses(data: BenchData, D: float) -> LossCheck:
    """Fit and check the loss family per temperature level of ``data`` at ``D`` [m³/rad].

    Raises
    ------
    InputError
        No torque column (``field="T"``), a non-positive ``D`` (``field="D"``), or no level
        with three speeds or more (``field="n"``; the reason of each level in the message).
    """
    if not (math.isfinite(D) and D > 0):
        raise InputError("the displacement must be finite and > 0", field="D")
    torque = data.torque
    if torque is None:
        raise InputError("the torque loss model needs a torque column", field="T")
    idx, lev = cluster_levels(data.theta, abs_gap=THETA_GAP, field="theta")
    mask = np.zeros(len(data), dtype=bool)
    q_pred = np.full(len(data), np.nan)
    t_pred = np.full(len(data), np.nan)
    levels: list[LevelCheck] = []
    skipped: list[str] = []
    for k in range(lev.size):
        sel = idx == k
        sub = PistonMap(data.dp[sel], data.omega[sel], data.q[sel], torque[sel],
                        np.full(int(sel.sum()), D))
        try:
            h = held_out_speed(sub, D)
        except InputError as exc:
            skipped.append(f"θ ≈ {lev[k]:.0f} °C not checked: {exc.message}")
            continue
        levels.append(LevelCheck(float(np.mean(data.theta[sel])), h))
        mask |= sel
        q_pred[sel] = h.flow_pred
        t_pred[sel] = h.torque_pred
    if not levels:
        raise InputError("; ".join(skipped), field="n")
    q, t = data.q[mask], torque[mask]
    flow_S = 100.0 * math.sqrt(float(np.mean((q - q_pred[mask]) ** 2))) / float(np.max(q))
    torque_S = 100.0 * math.sqrt(float(np.mean((t - t_pred[mask]) ** 2))) / float(np.max(t))
    return LossCheck(D, tuple(levels), tuple(skipped), mask, q_pred[mask], t_pred[mask],
                     flow_S, torque_S)
