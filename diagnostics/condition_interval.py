"""The stated condition's uncertainty in a one-parameter estimate's interval.

A record's covariance (:mod:`diagnostics.record_model`) carries the uncertainty of its
stated oil temperature and load as correlated terms ``s_k u_k``, with ``s_k`` the
sensitivity of the *healthy* rig's readings. A worn component's leakage is what makes the
readings feel the temperature (laminar leakage ∝ c³/μ(T): piston, paper 002 eqs. 36, 50;
spool, eq. 23; pump slip ∝ 1/μ, paper 000 eq. 6), so at a worn rig's estimate the
sensitivity is many times the healthy one: on the reference rig a seal at 2.5 × its
clearance read with its oil temperature stated 1 K off is fitted 1.5 % off, where the
posterior on the signature map gives ± 0.2 %; in the accuracy study the history's 95 %
intervals of single leakage faults read without flow meters held the truth in 76 %
(preset) and 75 % (differential rig) of the cases.

The interval of a one-parameter estimate ẑ is therefore widened to hold the estimator's
own spread with the stated conditions marginalised *at the estimate*.  Per record, with
``J = ∂ŷ/∂z`` (the secant of the signature map's segment holding ẑ; off the map, a
central difference of :data:`STEP` of the worn range), ``s_k = ∂ŷ/∂c_k`` at ẑ (one-sided
differences of 1 K and 1 % of the load, as :func:`diagnostics.record_model.
condition_moves` takes them, at the fitted parameter), ``C_h`` the covariance the fit
weighed the readings by and

.. math:: C = \\mathrm{diag}(u_i^2 + (ρ ŷ_i)^2) + \\sum_k s_k s_k^T u_k^2, \\qquad
          g = C_h^{-1} J, \\qquad
          σ_z^2 = \\frac{\\sum_{records} g^T C g}{(\\sum_{records} J^T g)^2}

(the sandwich: the linearised spread of the estimator actually used, whose weights come
from ``C_h``, under the covariance at the estimate; GUM Supplement 2 §6 for the
linearised propagation.  The information ``Σ JᵀC⁻¹J`` of the optimal weights would be
narrower than the estimator's spread: at 21 °C it gave ±0.7 % where a 1 K error moved
the fit 1.9 %.)  The interval is the hull of the posterior's and ẑ ± 1.96 σ_z, clipped to
the parameter's range.  Readings without a prediction there (a stalled stroke's) are
left out of the sums.

The same covariance gives each one-parameter fit's χ² at its estimate
(:func:`chi2_at_estimates`), with which the goodness-of-fit test and the ambiguity set
test again a fit they reject (:class:`SingleChecks`), and with which the evidences move
to each hypothesis's estimate (:mod:`diagnostics.evidence_at_fit`; a pair's estimate
through :func:`point_parts`).  Every prediction is a steady solve or a map look-up
(:meth:`diagnostics.signatures.SignatureMaps.observables_at_points`; on the fast path one
compiled call per record and moved condition for all estimates together).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from diagnostics.hypotheses import PARAMETERS, FaultParameter
from diagnostics.record_model import condition_moves
from diagnostics.shared_errors import shared_spread
from sim.errors import ParameterError

if TYPE_CHECKING:
    from diagnostics.ranking import HypothesisFit, ParameterEstimate, Ranker
    from diagnostics.record_model import RecordModel
    from diagnostics.signatures import Point

__all__ = ["STEP", "Parts", "SingleChecks", "check_singles", "chi2_at_estimates",
           "condition_sigmas", "covariances", "difference_steps", "estimate_parts",
           "joint_parts", "observable_pairs", "pair_points", "point_parts", "widen"]

Arr = npt.NDArray[np.float64]

#: step of the central difference ∂ŷ/∂z, as a share of the parameter's worn range in
#: fitting coordinates [-] (a clearance: 1.3e-3 of ln 4/1.1, 0.13 %)
STEP = 1.0e-3


#: per record: the predictions ŷ and ∂ŷ/∂z at each estimate and the condition terms
#: ``s_k u_k`` there (rows: estimates; columns: the record's readings)
Parts = list[tuple[Arr, Arr, list[Arr]]]


def estimate_parts(ranker: Ranker, params: Sequence[FaultParameter], zs: Arr) -> Parts:
    """:data:`Parts` of the one-parameter estimates ``zs[i]`` of ``params[i]``: on the
    signature maps where they can be, then one compiled call per record and moved
    condition for all of them."""
    return joint_parts(ranker, params, zs, [])[0]


def point_parts(ranker: Ranker, points: Sequence[Point]) -> Parts:
    """:data:`Parts` at estimates of several parameters each (a pair hypothesis's): the
    predictions and their central differences ``∂ŷ/∂z_k`` (:func:`difference_steps`;
    axes: estimates, readings, parameters) solved together, one compiled call per record,
    then the condition terms."""
    return joint_parts(ranker, [], np.empty(0), points)[1]


def joint_parts(ranker: Ranker, params: Sequence[FaultParameter], zs: Arr,
                points: Sequence[Point]) -> tuple[Parts, Parts]:
    """:func:`estimate_parts` of the one-parameter estimates ``zs[i]`` of ``params[i]``
    and :func:`point_parts` of ``points``, their condition terms solved together: one
    compiled call per record and moved condition for both (the pairs' and the singles'
    estimates at a moved condition were two calls each)."""
    zs = np.asarray(zs, dtype=np.float64)
    s_steps = difference_steps(ranker, params)
    singles: list[Point] = [((p,), (float(z),)) for p, z in zip(params, zs, strict=True)]
    steps = [difference_steps(ranker, ps) for ps, _ in points]
    moves: list[Point] = []
    for (ps, z), step in zip(points, steps, strict=True):
        for k in range(len(ps)):
            for sign in (1.0, -1.0):
                moved = list(z)
                moved[k] += sign * float(step[k])
                moves.append((ps, tuple(moved)))
    width = max((len(ps) for ps, _ in points), default=0)
    every = [*singles, *points]
    n = len(singles)
    out_s: Parts = []
    out_p: Parts = []
    for m in ranker.models:
        y0_s, jac_s = _at_estimates(m, params, zs, s_steps)
        y0_p = np.empty((0, m.idx.size))
        jac_p = np.full((len(points), m.idx.size, width), np.nan)
        if points:
            y = m.maps.observables_at_points([*points, *moves])[:, m.idx]
            y0_p, ym = y[:len(points)], y[len(points):]
            at = 0
            for j, step in enumerate(steps):
                k = 2 * step.size
                jac_p[j, :, :step.size] = (ym[at:at + k:2] - ym[at + 1:at + k:2]).T / (2.0 * step)
                at += k
        terms = _condition_terms(m, every, np.concatenate([y0_s, y0_p]))
        out_s.append((y0_s, jac_s, [t[:n] for t in terms]))
        out_p.append((y0_p, jac_p, [t[n:] for t in terms]))
    return out_s, out_p


def condition_sigmas(ranker: Ranker, params: Sequence[FaultParameter], zs: Arr,
                     parts: Parts | None = None) -> Arr:
    """σ_z of each one-parameter estimate ``zs[i]`` of ``params[i]`` with the stated
    conditions marginalised at the estimate (module docstring) [fitting coordinate];
    ∞ where no reading feels the parameter there.  ``parts``: those of
    :func:`estimate_parts`, computed here when not given."""
    zs = np.asarray(zs, dtype=np.float64)
    n = zs.size
    if parts is None:
        parts = estimate_parts(ranker, params, zs)
    num = np.zeros(n)
    den = np.zeros(n)
    weights: list[Arr] = []  # per record, G = C_h⁻¹ J of each estimate (0: not used)
    for m, (y0, jac, terms) in zip(ranker.models, parts, strict=True):
        g_all = np.zeros((n, m.idx.size))
        whole = np.isfinite(jac).all(axis=1) & np.isfinite(y0).all(axis=1)
        for t in terms:
            whole &= np.isfinite(t).all(axis=1)
        if whole.any():  # every reading predicted: all estimates at once
            # rows: the estimates' weights C_h⁻¹ J, with C_h⁻¹ = WᵀW (the fit's whitening)
            w = (jac[whole] @ m.white.T) @ m.white
            g_all[whole] = w
            num[whole] += np.sum(m.diag * w * w, axis=1) + sum(
                np.sum(t[whole] * w, axis=1) ** 2 for t in terms)
            den[whole] += np.sum(jac[whole] * w, axis=1)
        partial = np.flatnonzero(~whole)
        # the covariance the fit weighs by, where a reading has no prediction (its block)
        fitted = np.linalg.inv(m.white.T @ m.white) if partial.size else m.white
        for i in partial:
            cols = [t[i] for t in terms]
            ok = np.isfinite(jac[i]) & np.isfinite(y0[i])
            for c in cols:
                ok &= np.isfinite(c)
            if not ok.any():
                continue
            j = jac[i][ok]
            w_ok = np.linalg.solve(fitted[np.ix_(ok, ok)], j)
            g_all[i, ok] = w_ok
            cov = np.diag(m.diag[ok])
            for c in cols:
                cov += np.outer(c[ok], c[ok])
            num[i] += float(w_ok @ cov @ w_ok)
            den[i] += float(j @ w_ok)
        weights.append(g_all[:, :, None])
    # the instrument errors a joint visit's records share (:mod:`diagnostics.shared_errors`)
    cross = shared_spread(ranker.models, weights, [terms for _, _, terms in parts])
    if cross is not None:
        num = np.maximum(num + cross[:, 0, 0], 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0.0, np.sqrt(num) / den, math.inf)


def difference_steps(ranker: Ranker, params: Sequence[FaultParameter]) -> Arr:
    """The central-difference step of each parameter: :data:`STEP` of its worn range
    [fitting coordinate]."""
    bounds = [p.worn_bounds(ranker.rig) for p in params]
    return np.array([STEP * (p.to_z(hi) - p.to_z(lo))
                     for p, (lo, hi) in zip(params, bounds, strict=True)])


def _condition_terms(m: RecordModel, points: Sequence[Point], y0: Arr) -> list[Arr]:
    """``s_k u_k`` of record ``m`` at each estimate (rows; its readings' columns): one-sided
    differences of the stated conditions (:func:`~diagnostics.record_model.condition_moves`)
    at the fitted parameters, NaN where neither side has a steady point."""
    terms = []
    for u, moved in condition_moves(m.obs):
        sens = np.full_like(y0, np.nan)
        # the other side only where the first has no point (nothing to solve: no call)
        for cond, step in moved if points else ():
            try:
                y = m.maps.observables_at_points(points, cond)[:, m.idx]
            except ParameterError:  # past the circuit's range of conditions: the other side
                continue
            sens = np.where(np.isnan(sens), (y - y0) / step, sens)
            if not np.isnan(sens).any():
                break
        terms.append(sens * u)
    return terms


def chi2_at_estimates(ranker: Ranker, params: Sequence[FaultParameter], zs: Arr,
                      parts: Parts | None = None) -> Arr:
    """χ² of each one-parameter estimate ``zs[i]`` of ``params[i]`` with the covariance
    *at the estimate*: ``Σ_records rᵀ C⁻¹ r``, ``r`` the readings less the predictions at
    ẑ, ``C`` as in the module docstring (the stated conditions' sensitivities at the
    fitted parameter) [-]; ∞ where a reading has no prediction there (the fit's own χ²,
    which counts such a reading as masked, then stands).  ``parts`` as
    :func:`condition_sigmas` takes them."""
    zs = np.asarray(zs, dtype=np.float64)
    if parts is None:
        parts = estimate_parts(ranker, params, zs)
    return _chi2(ranker, parts, [covariances(m, terms, zs.size)
                                 for m, (_, _, terms) in zip(ranker.models, parts, strict=True)])


def _chi2(ranker: Ranker, parts: Parts, covs: list[Arr]) -> Arr:
    """:func:`chi2_at_estimates` from the records' stacked covariances ``covs``."""
    out = np.zeros(covs[0].shape[0] if covs else 0)
    for m, (y0, _, _), cov in zip(ranker.models, parts, covs, strict=True):
        r = m.obs.values - y0
        ok = np.isfinite(cov).all(axis=(1, 2)) & np.isfinite(r).all(axis=1)
        if ok.any():
            x = np.linalg.solve(cov[ok], r[ok][:, :, None])[:, :, 0]
            out[ok] += np.sum(r[ok] * x, axis=1)
        out[~ok] = math.inf
    return out


def covariances(m: RecordModel, terms: list[Arr], k: int) -> Arr:
    """Record ``m``'s covariance at each of ``k`` estimates (rows of ``terms``; module
    docstring), stacked ``(k, readings, readings)`` [SI²]; not finite where a sensitivity
    is not."""
    n = m.idx.size
    cov = np.broadcast_to(np.diag(m.diag), (k, n, n)).copy()
    with np.errstate(over="ignore", invalid="ignore"):  # a non-finite one stays so
        for t in terms:
            cov += t[:, :, None] * t[:, None, :]
    return cov


@dataclass
class SingleChecks:
    """The one-parameter fits of a diagnosis checked with the stated condition's
    sensitivity at their estimates, by hypothesis name: ``chi2`` (:func:`chi2_at_estimates`;
    the ambiguity set, :mod:`diagnostics.isolability`, and the goodness-of-fit test,
    :mod:`diagnostics.goodness`, test again with it a fit they reject) and ``sigma``
    (:func:`condition_sigmas`, fitting coordinate)."""

    chi2: dict[str, float] = field(default_factory=dict)
    sigma: dict[str, float] = field(default_factory=dict)
    #: the :data:`Parts` both were computed from, one row per name of ``chi2`` in order
    parts: Parts = field(default_factory=list)
    #: per record, the covariance at each estimate (:func:`covariances`) [SI²]
    covariance: list[Arr] = field(default_factory=list)
    #: the observable pairs' estimates (:func:`pair_points`) and their :data:`Parts`
    #: (:func:`point_parts`), solved with the singles' (:func:`joint_parts`) for
    #: :func:`diagnostics.evidence_at_fit.pair_at_fit`
    pair_points: list[Point] = field(default_factory=list)
    pair_parts: Parts = field(default_factory=list)

    def reading_sigma(self) -> dict[str, list[Arr]]:
        """Per fit (by name) and record, each reading's marginal σ with the covariance at
        the estimate [SI unit of the reading]."""
        return {name: [np.sqrt(np.diagonal(cov[i])) for cov in self.covariance]
                for i, name in enumerate(self.chi2)}


def observable_pairs(fits: Sequence[HypothesisFit]) -> list[HypothesisFit]:
    """The fitted pairs whose evidence moves to their estimates
    (:func:`diagnostics.evidence_at_fit.pair_at_fit`): observable, finite evidence."""
    return [f for f in fits if f.observable and len(f.parameters) > 1
            and math.isfinite(f.log_evidence)]


def pair_points(fits: Sequence[HypothesisFit]) -> list[Point]:
    """The estimates of fits ``fits`` as points: their parameters and fitting
    coordinates."""
    out: list[Point] = []
    for f in fits:
        ps = tuple(PARAMETERS[e.name] for e in f.parameters)
        out.append((ps, tuple(float(p.to_z(e.value)) for p, e in zip(ps, f.parameters,
                                                                     strict=True))))
    return out


def check_singles(ranker: Ranker, fits: Sequence[HypothesisFit]) -> SingleChecks:
    """:class:`SingleChecks` of the observable one-parameter fits with a finite χ², from one
    :func:`estimate_parts` (the σ of the intervals and the χ² of the tests share it); each
    fit's ``chi2_at_estimate`` is set.  The observable pairs' :func:`point_parts` are
    solved with them (:func:`joint_parts`) and kept."""
    todo = [f for f in fits if f.observable and len(f.parameters) == 1
            and math.isfinite(f.chi2)]
    if not todo:
        return SingleChecks()
    params = [PARAMETERS[f.parameters[0].name] for f in todo]
    zs = np.array([p.to_z(f.parameters[0].value) for p, f in zip(params, todo, strict=True)])
    points = pair_points(observable_pairs(fits))
    parts, p_parts = joint_parts(ranker, params, zs, points)
    covs = [covariances(m, terms, zs.size)
            for m, (_, _, terms) in zip(ranker.models, parts, strict=True)]
    chi2 = _chi2(ranker, parts, covs)
    for f, c in zip(todo, chi2, strict=True):
        f.chi2_at_estimate = float(c)
    sigma = condition_sigmas(ranker, params, zs, parts)
    return SingleChecks({f.name: float(c) for f, c in zip(todo, chi2, strict=True)},
                        {f.name: float(g) for f, g in zip(todo, sigma, strict=True)}, parts,
                        covs, points, p_parts)


def _at_estimates(m: RecordModel, params: Sequence[FaultParameter], zs: Arr, steps: Arr
                  ) -> tuple[Arr, Arr]:
    """Record ``m``'s predictions ŷ and ∂ŷ/∂z at each estimate (rows; its readings'
    columns): on the hypothesis's signature map where the estimate lies on it (linear
    between its fine points, the secant of that segment), else by steady solves at ẑ and
    ẑ ± ``steps`` (one call for all of them)."""
    n = zs.size
    y0 = np.full((n, m.idx.size), np.nan)
    jac = np.full_like(y0, np.nan)
    solve = []
    for i, (p, z) in enumerate(zip(params, zs, strict=True)):
        hm = next((h for h in m.maps.maps.values() if h.params == (p,)), None)
        axis = hm.axes[0] if hm is not None else None
        if hm is None or axis is None or not axis[0] <= z <= axis[-1]:
            solve.append(i)
            continue
        k = min(max(int(np.searchsorted(axis, z)), 1), axis.size - 1)
        a, b = hm.pred[k - 1, m.idx], hm.pred[k, m.idx]
        t = (z - axis[k - 1]) / (axis[k] - axis[k - 1])
        y0[i] = a + t * (b - a)
        jac[i] = (b - a) / (axis[k] - axis[k - 1])
        if not (np.isfinite(y0[i]).all() and np.isfinite(jac[i]).all()):
            solve.append(i)  # beside a masked point of the map: solve
    if solve:
        three = [params[i] for i in solve for _ in range(3)]
        points = np.stack([zs[solve] - steps[solve], zs[solve], zs[solve] + steps[solve]],
                          axis=1).reshape(-1)
        out = m.maps.observables_at(three, points)[:, m.idx].reshape(len(solve), 3, -1)
        y0[solve] = out[:, 1]
        jac[solve] = (out[:, 2] - out[:, 0]) / (2.0 * steps[solve, None])
    return y0, jac


def widen(ranker: Ranker, estimates: Sequence[tuple[FaultParameter, ParameterEstimate,
                                                    float, float]],
          sigmas: Sequence[float] | None = None) -> None:
    """Widen each estimate's 95 % interval in place to hold ẑ ± 1.96 σ_z
    (:func:`condition_sigmas`, or ``sigmas`` when given), clipped to its range
    ``(z_lo, z_hi)`` [fitting coordinate] given with it."""
    if not estimates:
        return
    params = [p for p, _, _, _ in estimates]
    zs = np.array([p.to_z(e.value) for p, e, _, _ in estimates])
    sig = condition_sigmas(ranker, params, zs) if sigmas is None else np.asarray(sigmas)
    for (p, e, z_lo, z_hi), z, s in zip(estimates, zs, sig, strict=True):
        if not math.isfinite(float(s)):
            continue
        lo = max(float(z - 1.96 * s), z_lo)
        hi = min(float(z + 1.96 * s), z_hi)
        if lo < p.to_z(e.low):
            e.low = p.from_z(lo)
        if hi > p.to_z(e.high):
            e.high = p.from_z(hi)
