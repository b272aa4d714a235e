"""Range test: does a fit pinned at a bound of its prior say the truth lies beyond it?

A hypothesis's parameters range over its *worn* prior (:mod:`diagnostics.hypotheses`).
When the best fit sits on a bound of that range, the χ² test of
:mod:`diagnostics.goodness` alone is not enough: a fit can pass it at the bound while the
likelihood still rises outward — the readings then ask for a fault beyond the library's
range (a leakage past 20 × nominal, a relief setting below 0.3 × nominal), or for a
component better than the rig document says (a seal length off its stated value reads as
a clearance below nominal).  Neither is the hypothesis as stated, so neither is a
confident answer.  Between the rig document's value and the start of the worn range
(leakage × 1 … 1.33) lies wear too small for the worn range: a fit pinned on that healthy
end is tested again against the document's value (:func:`_incipient`); readings that ask
for a value in between are *incipient* wear of the component (or a document off by that
much), which the goodness-of-fit test states as such instead of "better than the rig
document".

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

Both χ² values are taken from the same evaluator, so Λ compares like with like.  One
parameter is searched on a grid beyond its bound, refined on a second grid between the best
point's neighbours (three times) and by the vertex of the parabola through the best point
and its neighbours; two by Levenberg-Marquardt.  The evaluator is the compiled steady kernel of the
fast path when every record has fast maps (:meth:`diagnostics.fastpath.maps.FastMaps.
probe_moving`: a whole grid in one compiled call per record, points it fails solved
directly) and direct steady solves otherwise (:func:`diagnostics.pair_direct.residuals`,
Levenberg-Marquardt always); the two agree to the solver's tolerance
(``tests/diagnostics/test_range_test.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from scipy.special import gammaincinv

from diagnostics.fastpath.maps import FastMaps
from diagnostics.grid_vertex import bracket, parabola_vertex
from diagnostics.hypotheses import PARAMETERS, FaultParameter
from diagnostics.pair_direct import MASKED, levenberg_marquardt, residuals
from diagnostics.range_test_result import RangeTest

if TYPE_CHECKING:
    from diagnostics.ranking import HypothesisFit, Ranker
    from diagnostics.record_model import RecordModel

__all__ = ["RangeTest", "chi2_points", "grid_chi2", "parabola_vertex", "pinned", "range_test",
           "range_tests", "record_chi2"]

Arr = npt.NDArray[np.float64]

#: an estimate within this share of its range from a bound sits on it [-]
PIN_TOL = 1.0e-3

#: grid points of the one-parameter search beyond a bound, and of its refinement [-]
SCAN_POINTS = 24


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


def chi2_points(ranker: Ranker, params: list[FaultParameter], zs: Arr) -> Arr:
    """χ² of the one-parameter hypothesis ``params[i]`` at fitting coordinate ``zs[i]``
    for every point ``i``, as :func:`diagnostics.pair_direct.residuals` scores it (a
    masked reading counts ``MASKED`` σ): on the compiled kernel, all points in one call
    per record, when every record has fast maps; else by direct solves."""
    zs = np.asarray(zs, dtype=np.float64)
    if not all(isinstance(m.maps, FastMaps) for m in ranker.models):
        return np.array([_chi2(ranker, (p,), np.array([z])) for p, z in zip(params, zs,
                                                                             strict=True)])
    total = np.zeros(zs.size)
    for m in ranker.models:
        maps = m.maps
        assert isinstance(maps, FastMaps)
        out, _, _, _ = maps.probe_moving(params, [zs], [None])
        total += record_chi2(m, out)
    return total


def record_chi2(m: RecordModel, out: Arr) -> Arr:
    """χ² of record ``m`` at predicted observables ``out`` (rows: points), a masked
    reading counting ``MASKED`` σ."""
    resid = m.obs.values[None, :] - out[:, m.idx]
    whole = np.isfinite(resid).all(axis=1)
    r = np.empty_like(resid)
    r[whole] = m.whitened(resid[whole])
    part = resid[~whole] / m.sigma
    r[~whole] = np.where(np.isfinite(part), part, MASKED)
    return np.asarray(np.sum(r * r, axis=1))


def grid_chi2(ranker: Ranker, ps: list[FaultParameter], grids: Arr) -> tuple[Arr, _Known]:
    """:func:`_points` of grids fixed by the rig, not by the readings (row ``i``:
    parameter ``ps[i]``; the first search grids, :mod:`diagnostics.healthy_end`'s profile),
    and the points solved (:data:`_Known`): their predictions do not depend on the readings, so
    each record's maps keep them (:attr:`FastMaps.kept`, per parameter and grid) and a
    record at a condition seen before costs no solve; the missing rows are solved
    together, one call per record."""
    if not all(isinstance(m.maps, FastMaps) for m in ranker.models):
        return _points(ranker, ps, grids), []
    total = np.zeros(grids.shape)
    known: _Known = []
    for m in ranker.models:
        maps = m.maps
        assert isinstance(maps, FastMaps)
        keys = [("range grid", p.name, g.tobytes()) for p, g in zip(ps, grids, strict=True)]
        missing = [i for i, k in enumerate(keys) if k not in maps.kept]
        if missing:
            # solved from where every diagnosis at this condition starts, what the
            # solvers carry left as it was: the kept rows, and the fits after them, do not
            # depend on which record came first (a determinism pass)
            out, ys, _, ok = maps.probe_fresh(
                [ps[i] for i in missing for _ in range(grids.shape[1])],
                [grids[missing].reshape(-1)], [None])
            for j, i in enumerate(missing):
                sl = slice(j * grids.shape[1], (j + 1) * grids.shape[1])
                maps.kept[keys[i]] = (out[sl], ys[sl], ok[sl])
        rows = []
        for i, k in enumerate(keys):
            out_k, ys_k, ok_k = maps.kept[k]
            total[i] = record_chi2(m, out_k)
            rows.append((grids[i][ok_k], ys_k[ok_k]))
        known.append(rows)
    return total, known


#: per record, per search row: the points solved so far [fitting coordinate] and the
#: phases' solutions there, from which the next points of the row start
_Known = list[list[tuple[Arr, Arr]]]


def _points_near(ranker: Ranker, ps: list[FaultParameter], zs: Arr, known: _Known) -> Arr:
    """:func:`_points` of rows of equally spaced points, each row a run of the compiled
    solve started from the solution at the nearest point of its row solved before
    (``known``, extended in place), not from the last point of another row, of another
    parameter (measured on the diagnose bench's warm record, four faults pinned on their
    bounds: the three refinement levels 0.56 / 0.43 / 0.31 → 0.51 / 0.23 / 0.19 ms)."""
    if not known:
        return _points(ranker, ps, zs)
    rows, cols = zs.shape
    total = np.zeros((rows, cols))
    params = [p for p in ps for _ in range(cols)]
    for m, row_known in zip(ranker.models, known, strict=True):
        maps = m.maps
        assert isinstance(maps, FastMaps)
        starts: list[Arr | None] = []
        for i in range(rows):
            z_done, y_done = row_known[i]
            starts.append(y_done[int(np.argmin(np.abs(z_done - zs[i, 0])))]
                          if z_done.size else None)
        out, ys, _, ok = maps.probe_moving(params, list(zs), starts, even=True)
        total += record_chi2(m, out).reshape(rows, cols)
        for i in range(rows):
            sl = slice(i * cols, (i + 1) * cols)
            good = ok[sl]
            z_done, y_done = row_known[i]
            row_known[i] = (np.concatenate([z_done, zs[i][good]]),
                            np.concatenate([y_done, ys[sl][good]]))
    return total


@dataclass
class _Plan:
    """What a range test of one fit needs: its parameters, estimate, extended bounds and
    the pinned parameters that can be extended (index, side)."""

    fit: HypothesisFit
    params: tuple[FaultParameter, ...]
    z0: Arr
    zle: Arr
    zue: Arr
    used: list[tuple[int, str]]


def _plan(ranker: Ranker, fit: HypothesisFit) -> _Plan | None:
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
    return _Plan(fit, params, z0, zle, zue, used) if used else None


def range_test(ranker: Ranker, fit: HypothesisFit, level: float) -> RangeTest | None:
    """The range test of ``fit`` (module docstring); None when no parameter is pinned or
    the pinned side cannot be extended (a relief setting above its healthy end)."""
    return range_tests(ranker, [fit], level)[0]


def range_tests(ranker: Ranker, fits: list[HypothesisFit], level: float
                ) -> list[RangeTest | None]:
    """:func:`range_test` of each of ``fits``; the one-parameter searches of all of them
    run together (one compiled call per record and search stage)."""
    plans = [_plan(ranker, f) for f in fits]
    ones = [pl for pl in plans if pl is not None and len(pl.params) == 1]
    found = dict(zip((id(pl) for pl in ones), _search_1d(ranker, ones), strict=True))
    out: list[RangeTest | None] = []
    for pl in plans:
        if pl is None:
            out.append(None)
            continue
        if len(pl.params) == 1:
            chi2_b, z_best, chi2_e = found[id(pl)]
            ze = np.array([z_best])
        else:
            chi2_b = _chi2(ranker, pl.params, pl.z0)
            ze, chi2_e, _, _ = levenberg_marquardt(ranker.models, pl.params, pl.z0.copy(),
                                                   pl.zle, pl.zue)
        chi2_e = min(chi2_e, chi2_b)
        m = len(pl.used)
        limit = float(2.0 * gammaincinv(0.5 * m, 1.0 - level))
        stat = chi2_b - chi2_e if math.isfinite(chi2_b) else math.inf
        sides = [s for _, s in pl.used]
        rejected = bool(stat > limit)
        chi2_d = math.nan
        if rejected and "healthy" in sides:
            ze, chi2_d, sides, rejected = _incipient(ranker, pl, ze, chi2_e, limit)
        out.append(RangeTest(
            pl.fit.name, [pl.params[i].name for i, _ in pl.used], sides,
            chi2_b, chi2_e, stat, m, limit, rejected,
            {pl.params[i].name: pl.params[i].from_z(float(ze[i])) for i, _ in pl.used},
            chi2_d))
    return out


def _document_z(ranker: Ranker, p: FaultParameter) -> float:
    """The rig document's value of ``p`` in fitting coordinates (−∞ where the document
    has none: no seat leak)."""
    nominal = p.nominal_value(ranker.rig)
    return p.to_z(nominal) if nominal > 0.0 or not p.log else -math.inf


def _incipient(ranker: Ranker, pl: _Plan, ze: Arr, chi2_e: float, limit: float
               ) -> tuple[Arr, float, list[str], bool]:
    """A range rejected on its healthy side, tested again against the rig document.

    The worn range starts at the ``none`` severity limit (leakage × 1.33), not at the
    rig document's value; a component between the two is worn a little, or its document
    is off by that much, not "better than the rig document".  The constraint tested is
    then each healthy-side parameter ≥ its document value (the severe-side ones within
    their ranges, as before): χ²_d, the best χ² under it, against χ²_e as in the module
    docstring.  When χ²_d − χ²_e ≤ ``limit``, the healthy-side parameters whose best
    value under the constraint lies below the worn range are ``"incipient"``, at those
    values, and the range holds; one that sits on its document value is ``"document"``
    (the component is as built, the hypothesis blames it wrongly: rejected).  Otherwise
    rejected, each healthy-side parameter named by where its extended best lies.

    Returns the values (fitting coordinates), χ²_d, sides and whether the range is
    rejected.
    """
    zdoc = np.array([_document_z(ranker, p) for p in pl.params])
    zl, zu = (np.array(b) for b in zip(*(_bounds(ranker, p)[:2] for p in pl.params),
                                       strict=True))
    lo, hi = pl.zle.copy(), pl.zue.copy()
    for i, side in pl.used:
        if side == "healthy":
            lo[i] = max(float(zdoc[i]), float(pl.zle[i]))
        else:
            hi[i] = zu[i]
    if bool(np.all((ze >= lo) & (ze <= hi))):
        zd, chi2_d = ze, chi2_e
    elif len(pl.params) == 1:
        zd = np.clip(ze, lo, hi)
        chi2_d = float(chi2_points(ranker, list(pl.params), zd)[0])
    else:
        zd, chi2_d, _, _ = levenberg_marquardt(ranker.models, pl.params,
                                               np.clip(ze, lo, hi), lo, hi)
    tol = PIN_TOL * (zu - zl)
    if math.isfinite(chi2_d) and chi2_d - chi2_e <= limit:
        sides = [side if side != "healthy" else
                 "document" if zd[i] <= zdoc[i] + tol[i] else
                 "incipient" if zd[i] < zl[i] - tol[i] else side
                 for i, side in pl.used]
        return np.asarray(zd, dtype=np.float64), chi2_d, sides, "document" in sides
    sides = [side if side != "healthy" or ze[i] < zdoc[i] else "incipient"
             for i, side in pl.used]
    return ze, chi2_d, sides, True


def _search_1d(ranker: Ranker, plans: list[_Plan]) -> list[tuple[float, float, float]]:
    """(χ²_b, z, χ²_e) of each one-parameter plan: χ² at its estimate, and the best fit
    on its extended range (module docstring) — a grid, :data:`REFINE_LEVELS` grids each
    between the best point so far and its neighbours, then :data:`VERTEX_STEPS` vertices
    of the parabola through the best point and its neighbours."""
    if not plans:
        return []
    ps = [pl.params[0] for pl in plans]
    grids = np.array([np.linspace(pl.zle[0], pl.zue[0], SCAN_POINTS) for pl in plans])
    first, known = grid_chi2(ranker, ps, grids)
    chi_b = _finite(_points_near(ranker, ps, np.array([[pl.z0[0]] for pl in plans]),
                                 known))[:, 0]
    xs, ys = grids, _finite(first)
    for _ in range(REFINE_LEVELS):  # each level: a grid between the best point's neighbours
        fine = np.array([np.linspace(*bracket(x, y), REFINE_POINTS)
                         for x, y in zip(xs, ys, strict=True)])
        xs = np.concatenate([xs, fine], axis=1)
        ys = np.concatenate([ys, _finite(_points_near(ranker, ps, fine, known))], axis=1)
    for _ in range(VERTEX_STEPS):
        zv = np.array([parabola_vertex(x, y) for x, y in zip(xs, ys, strict=True)])
        cv = _finite(_points_near(ranker, ps, zv[:, None], known))
        xs = np.concatenate([xs, zv[:, None]], axis=1)
        ys = np.concatenate([ys, cv], axis=1)
    out = []
    for i, pl in enumerate(plans):
        j = int(np.argmin(ys[i]))
        if not math.isfinite(float(ys[i, j])):
            out.append((float(chi_b[i]), float(pl.z0[0]), math.inf))
        else:
            out.append((float(chi_b[i]), float(xs[i, j]), float(ys[i, j])))
    return out


#: refinement grids of the one-parameter search, their points, and the parabola-vertex
#: steps after them: the last grid's spacing is 2^L/((SCAN_POINTS − 1)·(REFINE_POINTS −
#: 1)^L) ≈ 2.6e-4 of the extended range for L = REFINE_LEVELS [-]
REFINE_LEVELS = 3
REFINE_POINTS = 12
VERTEX_STEPS = 1


def _points(ranker: Ranker, ps: list[FaultParameter], zs: Arr) -> Arr:
    """:func:`chi2_points` of rows of points, row ``i`` of parameter ``ps[i]``."""
    rows, cols = zs.shape
    flat = chi2_points(ranker, [p for p in ps for _ in range(cols)], zs.reshape(-1))
    return flat.reshape(rows, cols)


def _finite(chi: Arr) -> Arr:
    return np.where(np.isfinite(chi), chi, np.inf)
