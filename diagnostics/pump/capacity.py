"""Derived capacity (displacement) of a pump from steady test data (paper 001 §2.3).

Three methods, all on delivered flow ``q`` [m³/s] and speed ω [rad/s]; capacities in
[m³/rad] (× 2π for m³/rev):

* **ISO 8426 zero-pressure intercept** (Annex B, as paper 001 §2.3 describes it): plot
  q/ω against Δp, fit a straight line, take its intercept at Δp = 0.  Leakage that grows
  less than linearly with pressure (turbulent slip ∝ √Δp, laminar slip with a coefficient
  that falls with pressure as the side plates close, paper 000 §3.1) bends q/ω upward near
  Δp = 0, so the line underestimates the capacity and volumetric efficiencies above 100 %
  follow (paper 000 §3.1, paper 001 §2.3, Toet et al.).
* **Toet method** (Toet 1970, paper 001 §2.3): at each pressure, the slope ∂q/∂ω of flow
  versus speed; then the slopes against pressure, a straight line, its intercept at
  Δp = 0.  Slip that depends on pressure and viscosity but not on speed drops out of the
  slope; what is left is D·(1 − Δp/β_ef) and the speed dependence of the slip, both → 0
  at Δp = 0.
* **Vimax** (paper 001 §2.3): the largest q/ω over the steady points.  It gives at least one
  point with ηv = 100 % by construction and picks up the largest positive reading error.

Toet and intercept fit each oil-temperature level separately.  By default the estimate is
the one at the coldest level: the capacity is a geometric quantity, and what the methods
cannot separate from it (slip that is not linear in pressure for the intercept, slip that
depends on speed for Toet; paper 000 §3.1 reports both for this pump) scales with 1/μ, so the
most viscous oil biases it least.  ``level="all"`` combines the levels by inverse variance;
the per-level values are always reported, their spread is a check of the assumptions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from diagnostics.pump.data import BenchData
from diagnostics.pump.levels import cluster_levels
from sim.errors import InputError

__all__ = [
    "CapacityEstimate",
    "derived_capacity_intercept",
    "derived_capacity_toet",
    "derived_capacity_vimax",
    "volumetric_efficiency",
]

FloatArray = npt.NDArray[np.float64]

#: Temperature readings closer than this [K] are one temperature level.
THETA_GAP = 3.0


@dataclass(frozen=True, slots=True)
class CapacityEstimate:
    """A derived capacity.

    Attributes
    ----------
    method
        ``"iso8426-intercept"``, ``"toet"`` or ``"vimax"``.
    D
        Derived capacity [m³/rad].
    std
        Standard error of ``D`` [m³/rad] from the fit (NaN where the method has none).
    per_temperature
        ``{θ [°C]: D [m³/rad]}`` of each temperature level.
    """

    method: str
    D: float
    std: float
    per_temperature: dict[float, float] = field(default_factory=dict)

    @property
    def per_rev(self) -> float:
        """Derived capacity [m³/rev]."""
        return self.D * 2.0 * math.pi


def volumetric_efficiency(data: BenchData, D: float) -> FloatArray:
    """ηv = q / (D·ω) [-] of each point for a capacity ``D`` [m³/rad]."""
    if not D > 0:
        raise InputError("capacity must be positive", field="D")
    return data.q / (D * data.omega)


def _line(x: FloatArray, y: FloatArray, w: FloatArray | None = None) -> tuple[float, float,
                                                                            float, float]:
    """Weighted straight line y = a + b x: (a, b, se_a, se_b); se from the residual scatter."""
    if x.size < 3:
        raise InputError(f"a line through {x.size} points has no error estimate; need ≥ 3",
                         field="points")
    wt = np.ones_like(x) if w is None else w
    X = np.column_stack([np.ones_like(x), x]) * np.sqrt(wt)[:, None]
    yw = y * np.sqrt(wt)
    beta, *_ = np.linalg.lstsq(X, yw, rcond=None)
    r = yw - X @ beta
    s2 = float(r @ r) / (x.size - 2)
    cov = s2 * np.linalg.inv(X.T @ X)
    return float(beta[0]), float(beta[1]), math.sqrt(cov[0, 0]), math.sqrt(cov[1, 1])


def _combine(values: list[float], stds: list[float], thetas: list[float],
             level: Literal["coldest", "all"]) -> tuple[float, float]:
    if level == "coldest":
        k = int(np.argmin(thetas))
        return values[k], stds[k]
    if level != "all":
        raise InputError(f"level must be 'coldest' or 'all', got {level!r}", field="level")
    v = np.asarray(values)
    s = np.asarray(stds)
    if np.all(s > 0):
        w = 1.0 / s**2
        return float(np.sum(w * v) / np.sum(w)), float(1.0 / math.sqrt(np.sum(w)))
    return float(np.mean(v)), float(np.nan)


def derived_capacity_intercept(data: BenchData, *,
                               level: Literal["coldest", "all"] = "coldest") -> CapacityEstimate:
    """ISO 8426 zero-pressure intercept of q/ω against Δp (module doc; shows the bias).

    Parameters
    ----------
    data
        Steady points (one or more temperature levels; ≥ 3 points per level).
    level
        ``"coldest"``: the intercept at the coldest oil; ``"all"``: inverse-variance mean of
        the levels.

    Returns
    -------
    CapacityEstimate
        Derived capacity [m³/rad] and its standard error from the line fit.
    """
    t_idx, t_lev = cluster_levels(data.theta, rel_gap=0.0, abs_gap=THETA_GAP, field="theta")
    vals: list[float] = []
    stds: list[float] = []
    per: dict[float, float] = {}
    for k, theta in enumerate(t_lev):
        m = t_idx == k
        a, _, se, _ = _line(data.dp[m], data.q[m] / data.omega[m])
        vals.append(a)
        stds.append(se)
        per[round(float(theta), 2)] = a
    D, sd = _combine(vals, stds, list(t_lev), level)
    return CapacityEstimate("iso8426-intercept", D, sd, per)


def derived_capacity_toet(data: BenchData, *, min_speeds: int = 3,
                          level: Literal["coldest", "all"] = "coldest") -> CapacityEstimate:
    """Toet method: intercept at Δp = 0 of the slopes ∂q/∂ω against pressure.

    Parameters
    ----------
    data
        Steady points on a grid: at each of ≥ 3 pressure levels, ≥ ``min_speeds`` speed
        levels (readings are grouped into levels with :func:`cluster_levels`, 2 % gaps).
    min_speeds
        Fewest speed levels per pressure level for a slope [-].
    level
        ``"coldest"`` or ``"all"`` (see module doc).

    Returns
    -------
    CapacityEstimate
        Derived capacity [m³/rad] and its standard error.  Each slope ∂q/∂ω is a weighted
        line with weights 1/q² (the flowmeter error is a fraction of the reading); the line
        through the slopes is ordinary least squares.

    Raises
    ------
    InputError
        If fewer than 3 pressure levels have enough speeds (field ``n``).
    """
    t_idx, t_lev = cluster_levels(data.theta, rel_gap=0.0, abs_gap=THETA_GAP, field="theta")
    vals: list[float] = []
    stds: list[float] = []
    per: dict[float, float] = {}
    for k, theta in enumerate(t_lev):
        sub = data.subset(t_idx == k)
        p_idx, _ = cluster_levels(sub.dp, field="p_out")
        ps: list[float] = []
        slopes: list[float] = []
        for j in range(int(p_idx.max()) + 1):
            m = p_idx == j
            _, w_lev = cluster_levels(sub.omega[m], field="n")
            if w_lev.size < min_speeds or m.sum() < 3:
                continue
            _, b, _, _ = _line(sub.omega[m], sub.q[m], 1.0 / sub.q[m] ** 2)
            ps.append(float(np.mean(sub.dp[m])))
            slopes.append(b)
        if len(ps) < 3:
            levels = int(p_idx.max()) + 1
            _, speeds = cluster_levels(sub.omega, field="n")
            raise InputError(
                f"Toet method at {theta:.1f} °C needs ≥ 3 pressure levels with ≥ {min_speeds} "
                f"speeds each; the data have {levels} pressure level"
                f"{'s' if levels != 1 else ''} and {speeds.size} speed level"
                f"{'s' if speeds.size != 1 else ''} in all, {len(ps)} pressure level"
                f"{'s' if len(ps) != 1 else ''} with ≥ {min_speeds} speeds: a plan that is "
                "not such a grid (a Latin hypercube, paper 001) needs the displacement "
                "given (displacement_m3_rad; --displacement-cm3-rev)", field="n")
        a, _, se_a, _ = _line(np.asarray(ps), np.asarray(slopes))
        vals.append(a)
        stds.append(se_a)
        per[round(float(theta), 2)] = a
    D, sd = _combine(vals, stds, list(t_lev), level)
    return CapacityEstimate("toet", D, sd, per)


def derived_capacity_vimax(data: BenchData) -> CapacityEstimate:
    """Vimax: the largest q/ω of the data [m³/rad] (ηv = 1 at that point by construction)."""
    ratio = data.q / data.omega
    k = int(np.argmax(ratio))
    return CapacityEstimate("vimax", float(ratio[k]), float("nan"),
                            {round(float(data.theta[k]), 2): float(ratio[k])})
