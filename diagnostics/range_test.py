"""Range test: does a fit pinned at a bound of its prior say the truth lies beyond it?

A hypothesis's parameters range over its *worn* prior (:mod:`diagnostics.hypotheses`).
When the best fit sits on a bound of that range, the χ² test of
:mod:`diagnostics.goodness` alone is not enough: a fit can pass it at the bound while the
likelihood still rises outward — the readings then ask for a fault beyond the library's
range (a leakage past 20 × nominal, a relief setting below 0.3 × nominal), or for a
component better than the rig document says (a seal length off its stated value reads as
a clearance below nominal).  Neither is the hypothesis as stated, so neither is a
confident answer.

The test is the likelihood-ratio test of the range constraint (Self & Liang 1987,
*J. Am. Stat. Assoc.* 82:605, the boundary case): with χ²_b the χ² at the bounded
estimate and χ²_e the best χ² with each pinned parameter's range extended past its bound
(:meth:`~diagnostics.hypotheses.FaultParameter.extended_bounds`; the others kept in their
ranges),

.. math:: Λ = χ²_b − χ²_e, \\qquad \\text{reject the range when } Λ > χ²_{1-α}(m)

with ``m`` the number of pinned parameters and α the goodness-of-fit level.  At the
boundary Λ is asymptotically a mixture of χ²_0 … χ²_m (Self & Liang, Theorem 3), so the
χ²_m quantile is conservative: a truth inside the range (or on its bound) is rejected
with probability at most α.

Both χ² values are taken with direct steady solves (:func:`diagnostics.pair_direct.
residuals`), so Λ compares like with like; one parameter is searched on a grid beyond its
bound and refined by a bounded scalar minimisation, two by Levenberg-Marquardt.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from scipy.optimize import minimize_scalar
from scipy.special import gammaincinv

from diagnostics.hypotheses import PARAMETERS, FaultParameter
from diagnostics.pair_direct import levenberg_marquardt, residuals

if TYPE_CHECKING:
    from diagnostics.ranking import HypothesisFit, Ranker

__all__ = ["RangeTest", "pinned", "range_test"]

Arr = npt.NDArray[np.float64]

#: an estimate within this share of its range from a bound sits on it [-]
PIN_TOL = 1.0e-3

#: grid points of the one-parameter search beyond a bound [-]
SCAN_POINTS = 24


@dataclass
class RangeTest:
    """Likelihood-ratio test of a hypothesis's prior range (module docstring).

    Attributes
    ----------
    hypothesis
        Hypothesis tested.
    parameters
        Its parameters pinned at a bound.
    sides
        For each: ``"severe"`` (the fault would be larger than the range allows) or
        ``"healthy"`` (the component would be better than the rig document says).
    chi2_bounded, chi2_extended
        χ² at the bounded estimate and at the best fit with the ranges extended [-].
    statistic
        Λ = χ²_b − χ²_e [-].
    dof
        Number of pinned parameters m [-].
    limit
        χ²_{1-α}(m) [-].
    rejected
        Λ > limit: the readings ask for a value beyond the range.
    extended
        The best values beyond the range, by parameter [unit of the parameter].
    """

    hypothesis: str
    parameters: list[str]
    sides: list[str]
    chi2_bounded: float
    chi2_extended: float
    statistic: float
    dof: int
    limit: float
    rejected: bool
    extended: dict[str, float] = field(default_factory=dict)

    def describe(self) -> str:
        """One clause for a reader."""
        what = ", ".join(
            f"{p} {'beyond its worn range' if s == 'severe' else 'better than the rig document'}"
            f" (best {self.extended.get(p, math.nan):.4g})"
            for p, s in zip(self.parameters, self.sides, strict=True))
        return (f"{self.hypothesis} sits on the bound of its prior and its likelihood still "
                f"rises past it ({what}: χ² {self.chi2_bounded:.3g} → "
                f"{self.chi2_extended:.3g}, Λ = {self.statistic:.3g} > {self.limit:.3g})")


def _bounds(ranker: Ranker, p: FaultParameter) -> tuple[float, float, float, float]:
    """(zl, zu, zl_ext, zu_ext) of ``p`` in fitting coordinates."""
    lo, hi = p.worn_bounds(ranker.rig)
    elo, ehi = p.extended_bounds(ranker.rig)
    return p.to_z(lo), p.to_z(hi), p.to_z(min(elo, lo)), p.to_z(max(ehi, hi))


def pinned(ranker: Ranker, fit: HypothesisFit) -> list[tuple[int, str]]:
    """(index, side) of each parameter of ``fit`` that sits on a bound of its range."""
    out = []
    for i, est in enumerate(fit.parameters):
        p = PARAMETERS[est.name]
        zl, zu, _, _ = _bounds(ranker, p)
        z = p.to_z(est.value)
        tol = PIN_TOL * (zu - zl)
        severe_low = p.name == "Pset"  # a setting drifts down; the others wear upward
        if z - zl <= tol:
            out.append((i, "severe" if severe_low else "healthy"))
        elif zu - z <= tol:
            out.append((i, "healthy" if severe_low else "severe"))
    return out


def _chi2(ranker: Ranker, params: tuple[FaultParameter, ...], z: Arr) -> float:
    r, _ = residuals(ranker.models, params, z)
    return float(r @ r)


def range_test(ranker: Ranker, fit: HypothesisFit, level: float) -> RangeTest | None:
    """The range test of ``fit`` (module docstring); None when no parameter is pinned or
    the pinned side cannot be extended (a relief setting above its healthy end)."""
    pins = pinned(ranker, fit)
    params = tuple(PARAMETERS[e.name] for e in fit.parameters)
    z0 = np.array([p.to_z(e.value) for p, e in zip(params, fit.parameters, strict=True)])
    zl = np.empty(len(params))
    zu = np.empty(len(params))
    for i, p in enumerate(params):
        zl[i], zu[i], _, _ = _bounds(ranker, p)
    zle, zue = zl.copy(), zu.copy()
    used = []
    for i, side in pins:
        _, _, lo_e, hi_e = _bounds(ranker, params[i])
        at_low = z0[i] - zl[i] <= PIN_TOL * (zu[i] - zl[i])
        if at_low and lo_e < zl[i]:
            zle[i] = lo_e
        elif not at_low and hi_e > zu[i]:
            zue[i] = hi_e
        else:
            continue
        used.append((i, side))
    if not used:
        return None
    chi2_b = _chi2(ranker, params, z0)
    if len(params) == 1:
        z_best, chi2_e = _search_1d(ranker, params, float(zle[0]), float(zue[0]), float(z0[0]))
        ze = np.array([z_best])
    else:
        ze, chi2_e, _, _ = levenberg_marquardt(ranker.models, params, z0.copy(), zle, zue)
    chi2_e = min(chi2_e, chi2_b)
    m = len(used)
    limit = float(2.0 * gammaincinv(0.5 * m, 1.0 - level))
    stat = chi2_b - chi2_e if math.isfinite(chi2_b) else math.inf
    return RangeTest(fit.name, [params[i].name for i, _ in used], [s for _, s in used],
                     chi2_b, chi2_e, stat, m, limit, bool(stat > limit),
                     {params[i].name: params[i].from_z(float(ze[i])) for i, _ in used})


def _search_1d(ranker: Ranker, params: tuple[FaultParameter, ...], zlo: float, zhi: float,
               z0: float) -> tuple[float, float]:
    """(z, χ²) of the best one-parameter fit on [zlo, zhi]: a grid, then a bounded
    scalar minimisation between the best grid point's neighbours."""
    grid = np.linspace(zlo, zhi, SCAN_POINTS)
    chi = np.array([_chi2(ranker, params, np.array([z])) for z in grid])
    chi = np.where(np.isfinite(chi), chi, np.inf)
    k = int(np.argmin(chi))
    if not math.isfinite(float(chi[k])):
        return z0, math.inf
    a, b = float(grid[max(k - 1, 0)]), float(grid[min(k + 1, grid.size - 1)])
    res = minimize_scalar(lambda z: _chi2(ranker, params, np.array([z])), bounds=(a, b),
                          method="bounded", options={"xatol": 1e-4 * (zhi - zlo)})
    if math.isfinite(float(res.fun)) and float(res.fun) < float(chi[k]):
        return float(res.x), float(res.fun)
    return float(grid[k]), float(chi[k])
