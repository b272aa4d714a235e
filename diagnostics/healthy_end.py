"""A component's value when its single-fault fit sits on the healthy end of its worn range.

A single-fault hypothesis's parameter ranges over the component's *worn* prior
(:meth:`~diagnostics.hypotheses.FaultParameter.worn_bounds`: from leakage × 1.33 up), so
the fit of a component worn less than that, or not at all, sits on that end with its 95 %
interval clipped there: a healthy piston seal (clearance at the rig document's 83 µm) is
fitted at the worn range's start, 91.3 µm, with an interval [91.3, 93.6] µm that
excludes the truth.  That is right for the hypothesis (a worn seal is at least that worn)
and wrong for what the history keeps of the component: its value over time, which starts
at the document's value and passes through the gap before the worn range while it wears
(the first points of every trend).

For the component's value the parameter is profiled from the rig document's value up:
χ²(z) of the one-parameter hypothesis on :data:`POINTS` equally spaced fitting
coordinates from the document's value z_d to z_l + (z_l − z_d), z_l the worn range's
start (twice the gap; fixed by the rig, not by the readings, so a record at a condition
seen before reuses the grid's predictions, :func:`~diagnostics.range_test.grid_chi2`).
The estimate is the grid's minimum refined by the parabola through it and its neighbours
(:func:`~diagnostics.grid_vertex.parabola_vertex`); the 95 % interval is the profile
likelihood's, where χ²(z) − χ²_min ≤ 1.96² (Wilks; the χ²₁ quantile), its ends
interpolated linearly between grid points and clipped at the document's value (below it
the component would be better than built: :mod:`diagnostics.range_test` says whether the
readings ask for that).  Where the profile stays under the threshold to the grid's top,
the upper end is the fit's own (its posterior interval from the worn range's start, which
bounds the profile's from above). :func:`diagnostics.diagnose.diagnose` then widens the
interval for the stated condition at the estimate
(:mod:`diagnostics.condition_interval`). The χ² is evaluated as the range test evaluates
its first grids (:func:`~diagnostics.range_test.grid_chi2`, the compiled kernel when every
record has fast maps).  A fit *inside* its worn range whose interval reaches the range's start (the
posterior cut there: a pump leaking 1.2 × nominal fitted at 1.6 × with an interval from
1.33 ×) keeps its estimate and upper end, and takes the profile's lower end: where χ²
rises 1.96² above the fit's, going down from the range's start toward the document's
value.  A profile whose best χ² fails the goodness-of-fit test
(:mod:`diagnostics.goodness`) estimates nothing: no value of that component alone, from
its document's up, explains the readings.  Whether the component is the likely culprit
is the ranking's business; the profile is its value if it is the one that moved
(the single-fault assumption every hypothesis estimate makes).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from diagnostics.fastpath.maps import FastMaps
from diagnostics.goodness import TEST_LEVEL, chi2_limit
from diagnostics.hypotheses import PARAMETERS, FaultParameter
from diagnostics.range_test import PIN_TOL, grid_chi2, parabola_vertex, pinned
from diagnostics.ranking import ParameterEstimate, severity

if TYPE_CHECKING:
    from diagnostics.ranking import HypothesisFit, Ranker

__all__ = ["POINTS", "PROFILED", "healthy_end_estimates"]

Arr = npt.NDArray[np.float64]

#: grid points of the profile from the rig document's value [-]: a spacing of 1/16 of
#: the gap between the document's value and the worn range (0.6 % of a clearance)
POINTS = 33

#: parameters profiled: those whose rig document gives a value below the worn range
#: (a relief setting's healthy end is its document value; a seat leak has none) [-]
PROFILED = ("cc", "cv", "pump_leak")

#: Δχ² of the 95 % profile-likelihood interval: 1.96², the χ²₁ 95 % quantile [-]
DELTA_95 = 1.96 ** 2


def _grid(ranker: Ranker, p: FaultParameter) -> Arr:
    zd = p.to_z(p.nominal_value(ranker.rig))
    zl = p.to_z(p.worn_bounds(ranker.rig)[0])
    return np.linspace(zd, zl + (zl - zd), POINTS)


def _profile(ranker: Ranker, ps: list[FaultParameter], grids: Arr) -> Arr:
    """χ² of row ``i`` of ``grids`` under the one-parameter hypothesis of ``ps[i]``
    (:func:`~diagnostics.range_test.grid_chi2`: each record's rows in one compiled call,
    kept on its maps by parameter and grid); the kernel's continuation is left where it
    was, so the fits that follow at this condition start as they would have."""
    fast = [m.maps for m in ranker.models if isinstance(m.maps, FastMaps)]
    saved = [maps.ctx.states.copy() for maps in fast]
    chi, _ = grid_chi2(ranker, ps, grids)
    for maps, states in zip(fast, saved, strict=True):
        maps.ctx.states[:] = states
    return np.where(np.isfinite(chi), chi, np.inf)


def _crossing(z: Arr, chi: Arr, j: int, level: float, step: int) -> float | None:
    """The fitting coordinate where ``chi`` first rises above ``level`` going from index
    ``j`` by ``step`` (linear between grid points); None when it never does."""
    k = j
    while 0 <= k + step < z.size:
        if chi[k + step] > level:
            if not math.isfinite(float(chi[k + step])):
                return float(z[k + step])
            t = (level - chi[k]) / (chi[k + step] - chi[k])
            return float(z[k] + t * (z[k + step] - z[k]))
        k += step
    return None


def _touches(ranker: Ranker, f: HypothesisFit) -> bool:
    """Whether the 95 % interval of one-parameter fit ``f`` (estimate inside its worn
    range) reaches the range's healthy end: the posterior there is cut by the range."""
    (est,) = f.parameters
    p = PARAMETERS[est.name]
    zl, zu = (p.to_z(b) for b in p.worn_bounds(ranker.rig))
    return p.to_z(est.low) - zl <= PIN_TOL * (zu - zl)


def healthy_end_estimates(ranker: Ranker, fits: list[HypothesisFit],
                          level: float = TEST_LEVEL) -> dict[str, ParameterEstimate]:
    """The profile estimate (module docstring) of each of ``fits`` that has one parameter
    of :data:`PROFILED` and sits on the healthy end of its worn range, by hypothesis name,
    when the profile's best χ² passes the goodness-of-fit test at ``level``
    (χ²_{1−α}(n − 1), n readings; no test without a degree of freedom): a component whose
    every value from its document's up leaves the readings unexplained estimates nothing
    (:mod:`diagnostics.goodness`).  A fit inside its worn range whose interval reaches the
    range's healthy end keeps its estimate and upper end; its lower end is the profile's,
    where χ² rises 1.96² above the fit's going down toward the document's value."""
    todo = []
    for f in fits:
        if len(f.parameters) != 1 or f.parameters[0].name not in PROFILED:
            continue
        if any(side == "healthy" for _, side in pinned(ranker, f)):
            todo.append((f, True))
        elif not pinned(ranker, f) and math.isfinite(f.chi2) and _touches(ranker, f):
            todo.append((f, False))
    if not todo:
        return {}
    ps = [PARAMETERS[f.parameters[0].name] for f, _ in todo]
    grids = np.array([_grid(ranker, p) for p in ps])
    chi = _profile(ranker, ps, grids)
    dof = ranker.n_obs - 1
    limit = chi2_limit(level, dof) if dof >= 1 else math.inf
    out: dict[str, ParameterEstimate] = {}
    for (f, on_end), p, z, c in zip(todo, ps, grids, chi, strict=True):
        fitted = f.parameters[0]
        j = int(np.argmin(c))
        if not float(c[j]) <= limit:
            continue
        if not on_end:  # the worn range's start is the grid's middle point
            low = _crossing(z, c, POINTS // 2, min(f.chi2, float(c[j])) + DELTA_95, -1)
            out[f.name] = replace(fitted, low=fitted.nominal if low is None else
                                  p.from_z(low))
            continue
        best = parabola_vertex(z, c) if 0 < j < z.size - 1 else float(z[j])
        threshold = float(c[j]) + DELTA_95
        low = _crossing(z, c, j, threshold, -1)
        high = _crossing(z, c, j, threshold, +1)
        hi = max(p.to_z(fitted.high), float(z[-1])) if high is None else high
        at_document = best <= z[0]
        value = fitted.nominal if at_document else p.from_z(best)
        mult, label = severity(p, value, fitted.nominal)
        out[f.name] = ParameterEstimate(
            p.name, p.component, p.unit, value,
            fitted.nominal if low is None else p.from_z(low), p.from_z(hi), fitted.nominal,
            mult, label, bool(at_document))
    return out
