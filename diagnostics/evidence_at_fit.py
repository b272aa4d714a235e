"""The stated condition's uncertainty at each hypothesis's estimate in its evidence.

The ranking (:mod:`diagnostics.ranking`) weighs every hypothesis's residuals by one
covariance per record, ``C_h``, whose correlated terms carry the stated oil temperature's
and load's uncertainty through the *healthy* rig's sensitivities
(:mod:`diagnostics.record_model`).  A worn component's leakage is what makes the readings
feel the temperature (laminar leakage ∝ c³/μ(T): piston, paper 002 eqs. 36, 50; spool,
eq. 23; pump slip ∝ 1/μ, paper 000 eq. 6), so at a worn estimate a thermometer's error
moves the readings many times more than on the healthy rig.  Weighed by ``C_h``, that
movement looks like a misfit that only a second fault can absorb.

The likelihood of a hypothesis is ``N(y; ŷ(θ), C(θ))``, its covariance the one *at* its
parameters (linearised in the stated condition: the condition marginalised, GUM
Supplement 2 §6).  Each observable fitted hypothesis's evidence is therefore computed
again with every record's covariance taken at its estimate, ``C = C(θ̂)``, the Gaussian's
normalisation included (``−½ ln|C|`` against ``−½ ln|C_h|``: a covariance that grows
with the wear pays for what it lets the readings do):

* a single fault is integrated again on its signature map, as the ranking integrates it
  (:func:`diagnostics.evidence.map_log_evidence`), its χ² whitened by ``C`` — the peak
  moves, and the posterior widens or narrows with ``C``;
* a pair's Laplace evidence (:func:`diagnostics.pair_evidence.laplace_evidence`: peak,
  Gauss-Newton width, the bounds' truncation) is evaluated at its estimate with the
  residuals and Jacobian whitened by ``C`` and by ``C_h``, and the difference moves the
  ranking's evidence (its ridge profile, where it has one, is kept).

``C`` is held at the estimate across the integral (where it differs much from there the
likelihood is negligible either way), and a pair is not refitted. Healthy keeps the
healthy covariance. The probabilities are then the fleet prior times these evidences
(:func:`diagnostics.evidence.posterior`) and the fits are ordered again. Measured: a
noise-free visit of a seal at 6 × its leakage, three loads, temperatures stated +1/−1/+1
K, no flow meters, was ranked ``cylinder+pump`` p 0.97 and is ``cylinder`` p 0.996; in
the accuracy study (``make accuracy``) the expected calibration error of the stated
probabilities went from 0.026/0.022/0.039 to 0.019/0.012/0.017 (full sensors / no flow
meters / velocity ratio alone), with another seed of its draws from 0.031/0.039/0.018 to
0.027/0.033/0.033, and joint visits without flow meters were named 72 → 80 % and 62 → 78
% of the time.

A pair's interval comes from the same computation: the sandwich spread of its
Gauss-Newton estimator under ``C`` (:func:`pair_at_fit`), which
:func:`diagnostics.diagnose.diagnose` widens its intervals to hold.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from diagnostics.condition_interval import (
    Parts,
    SingleChecks,
    covariances,
    observable_pairs,
    pair_points,
    point_parts,
)
from diagnostics.evidence import map_log_evidence, map_support, posterior
from diagnostics.hypotheses import PARAMETERS
from diagnostics.pair_evidence import laplace_evidence
from diagnostics.ranking import HypothesisFit, rank_order
from diagnostics.shared_errors import shared_spread

if TYPE_CHECKING:
    from diagnostics.ranking import Ranker
    from diagnostics.record_model import RecordModel

__all__ = ["AtFit", "evidence_at_fit", "pair_at_fit", "singles_log_evidence"]

Arr = npt.NDArray[np.float64]


@dataclass
class AtFit:
    """What :func:`evidence_at_fit` computed, by hypothesis name: ``shift``, the change of
    each moved log-evidence [-]; ``pair_sigma``, each pair's σ_z per parameter with the
    stated condition at its estimate (the sandwich of :func:`pair_at_fit`) [fitting
    coordinate]; ``pair_reading_sigma`` below."""

    shift: dict[str, float] = field(default_factory=dict)
    pair_sigma: dict[str, Arr] = field(default_factory=dict)
    #: each pair's readings' marginal σ per record with the covariance at its estimate
    #: [SI unit of the reading]
    pair_reading_sigma: dict[str, list[Arr]] = field(default_factory=dict)


def evidence_at_fit(ranker: Ranker, fits: list[HypothesisFit], checks: SingleChecks
                    ) -> AtFit:
    """Move each observable fitted hypothesis's ``log_evidence`` to the covariance at its
    estimate (module docstring), recompute the probabilities and reorder ``fits`` in
    place; the pairs' σ for their intervals come with it (:class:`AtFit`)."""
    out = AtFit()
    shift = out.shift
    names = list(checks.chi2)
    for name, log_ev in zip(names, singles_log_evidence(ranker, names, checks.covariance),
                            strict=True):
        fit = next(f for f in fits if f.name == name)
        if log_ev is not None and math.isfinite(log_ev - fit.log_evidence):
            shift[name] = log_ev - fit.log_evidence
    pairs = observable_pairs(fits)
    known = checks.pair_parts if checks.pair_points == pair_points(pairs) else None
    for f, got in zip(pairs, pair_at_fit(ranker, pairs, known), strict=True):
        if got is not None and math.isfinite(got[0]):
            (shift[f.name], out.pair_sigma[f.name], out.pair_reading_sigma[f.name],
             f.chi2_at_estimate) = got
    for f in fits:
        if f.name in shift:
            f.log_evidence += shift[f.name]
    posterior(fits)
    fits.sort(key=rank_order)
    return out


def _sandwich_sd(a: Arr, b: Arr) -> Arr:
    """√diag(A⁻¹ B A⁻¹) of the 2×2 sandwich of :func:`pair_at_fit` [fitting coordinate]
    (closed form, pairs have two parameters; ∞ where ``A`` is singular: a flat direction
    has no width to state)."""
    a00, a01, a10, a11 = float(a[0, 0]), float(a[0, 1]), float(a[1, 0]), float(a[1, 1])
    det = a00 * a11 - a01 * a10
    if det == 0.0 or not math.isfinite(det):
        return np.full(2, math.inf)
    i00, i01, i10, i11 = a11 / det, -a01 / det, -a10 / det, a00 / det
    b00, b01, b10, b11 = float(b[0, 0]), float(b[0, 1]), float(b[1, 0]), float(b[1, 1])
    # (A⁻¹ B A⁻¹)_kk = Σ_ij A⁻¹_ki B_ij A⁻¹_jk
    v0 = i00 * (b00 * i00 + b01 * i10) + i01 * (b10 * i00 + b11 * i10)
    v1 = i10 * (b00 * i01 + b01 * i11) + i11 * (b10 * i01 + b11 * i11)
    return np.array([math.sqrt(max(v0, 0.0)), math.sqrt(max(v1, 0.0))])


def _factors(cov: Arr) -> tuple[Arr, npt.NDArray[np.bool_]]:
    """Stacked covariances ``cov`` (:func:`~diagnostics.condition_interval.covariances`)
    factored by Cholesky: the lower factors (the identity where there is none) and whether
    each could be formed."""
    cov = cov.copy()
    ok = np.asarray(np.isfinite(cov).all(axis=(1, 2)), dtype=np.bool_)
    cov[~ok] = np.eye(cov.shape[1])
    try:
        return np.asarray(np.linalg.cholesky(cov), dtype=np.float64), ok
    except np.linalg.LinAlgError:  # one of them is not positive definite: each on its own
        chol = np.empty_like(cov)
        for i in range(cov.shape[0]):
            try:
                chol[i] = np.linalg.cholesky(cov[i])
            except np.linalg.LinAlgError:
                chol[i], ok[i] = np.eye(cov.shape[1]), False
        return chol, ok


def _log_det_change(m: RecordModel, chol: Arr) -> Arr:
    """ln |C| − ln |C_h| of record ``m`` for stacked Cholesky factors of C [-]."""
    return 2.0 * np.sum(np.log(np.diagonal(chol, axis1=-2, axis2=-1)), axis=-1) - m.log_det


def singles_log_evidence(ranker: Ranker, names: list[str], covs: list[Arr]
                         ) -> list[float | None]:
    """ln Z of each single fault ``names[i]`` on its signature map with every record's
    covariance taken at its estimate (``covs``: per record, row ``i`` stacked;
    :attr:`~diagnostics.condition_interval.SingleChecks.covariance`), the Gaussian's
    normalisation relative to the ranking's included [-]; None where that covariance
    cannot be formed (a sensitivity without a steady point on either side).  All of them
    at once."""
    if not names:
        return []
    chi2 = np.zeros((len(names), ranker.models[0].maps.maps[names[0]].axes[0].size))
    log_det = np.zeros(len(names))
    ok = np.ones(len(names), dtype=bool)
    for m, cov in zip(ranker.models, covs, strict=True):
        chol, formed = _factors(cov)
        ok &= formed
        resid = m.obs.values - np.stack([m.maps.maps[n].pred[:, m.idx] for n in names])
        # L⁻¹ r for every map point: the factors inverted once (7 × 7 each), then one
        # product, where a solve per factor took 4× as long (49 → 12 µs, measured)
        white = np.linalg.inv(chol) @ np.swapaxes(resid, 1, 2)
        c = np.sum(white * white, axis=1)
        chi2 += np.where(np.isnan(c), np.inf, c)  # a masked prediction: impossible
        log_det += _log_det_change(m, chol)
    return [map_log_evidence(chi2[i], map_support(ranker, n)) - 0.5 * float(log_det[i])
            if ok[i] else None for i, n in enumerate(names)]


def pair_at_fit(ranker: Ranker, pairs: list[HypothesisFit], parts: Parts | None = None
                ) -> list[tuple[float, Arr, list[Arr], float] | None]:
    """Per pair, the change of its ln Z from the ranking's covariance ``C_h`` to the one at
    its estimate ``C`` [-], its parameters' σ_z with the stated condition there [fitting
    coordinate], per record its readings' marginal σ under ``C`` [SI unit of the
    reading] and its χ² under ``C`` [-]; None where a reading has no prediction or ``C``
    cannot be formed there.

    The change is the Laplace evidence (:func:`diagnostics.pair_evidence.laplace_evidence`:
    peak, Gauss-Newton width and the bounds' truncation) with the residuals and the
    Jacobian ``J`` (central differences of :data:`~diagnostics.condition_interval.STEP`
    of each worn range) whitened by either, less half the change of ln |C|.  σ_z is the
    sandwich of the estimator the fit used, ``A⁻¹ B A⁻¹`` with ``A = Σ Jᵀ C_h⁻¹ J`` and
    ``B = Σ Jᵀ C_h⁻¹ C C_h⁻¹ J`` (:mod:`diagnostics.condition_interval` for one
    parameter); with the condition stated exactly it is the Gauss-Newton σ.  All pairs
    at once, per record; ``parts``: the pairs' :func:`~diagnostics.condition_interval.
    point_parts` where already solved (:attr:`~diagnostics.condition_interval.
    SingleChecks.pair_parts`)."""
    if not pairs:
        return []
    params = [tuple(PARAMETERS[e.name] for e in f.parameters) for f in pairs]
    zs = [np.array([p.to_z(e.value) for p, e in zip(ps, f.parameters, strict=True)])
          for ps, f in zip(params, pairs, strict=True)]
    if parts is None:
        parts = point_parts(ranker, pair_points(pairs))
    n_pairs, width = len(pairs), max(len(ps) for ps in params)
    cost = np.zeros((2, n_pairs))
    jacs: list[list[Arr]] = [[], []]  # per whitening, per record: (pairs, readings, width)
    spread = np.zeros((n_pairs, width, width))
    log_det = np.zeros(n_pairs)
    ok = np.ones(n_pairs, dtype=bool)
    marginal: list[Arr] = []
    g_records: list[Arr] = []
    for m, (y0, jac, terms) in zip(ranker.models, parts, strict=True):
        chol, formed = _factors(covariances(m, terms, n_pairs))
        r = m.obs.values - y0
        ok &= formed & np.isfinite(r).all(axis=1) & np.isfinite(jac).all(axis=(1, 2))
        both = np.concatenate([r[:, :, None], jac], axis=2)  # (pairs, readings, 1 + width)
        for w, whitened in enumerate((np.einsum("ij,pjk->pik", m.white, both),
                                      np.linalg.solve(chol, both))):
            cost[w] += np.sum(whitened[:, :, 0] ** 2, axis=1)
            jacs[w].append(whitened[:, :, 1:])
        g = np.einsum("ji,pjk->pik", m.white, jacs[0][-1])  # C_h⁻¹ J
        g_records.append(g)
        weights = np.swapaxes(chol, 1, 2) @ g
        spread += np.swapaxes(weights, 1, 2) @ weights  # (Lᵀ C_h⁻¹ J)ᵀ (Lᵀ C_h⁻¹ J)
        marginal.append(np.sqrt(np.sum(chol * chol, axis=2)))  # √diag(L Lᵀ)
        log_det += _log_det_change(m, chol)
    # the instrument errors a joint visit's records share (:mod:`diagnostics.shared_errors`)
    cross = shared_spread(ranker.models, g_records, [terms for _, _, terms in parts])
    if cross is not None:
        spread = spread + cross
    out: list[tuple[float, Arr, list[Arr], float] | None] = []
    for j, (ps, z) in enumerate(zip(params, zs, strict=True)):
        if not ok[j]:
            out.append(None)
            continue
        bounds = [p.worn_bounds(ranker.rig) for p in ps]
        zl = np.array([p.to_z(b[0]) for p, b in zip(ps, bounds, strict=True)])
        zu = np.array([p.to_z(b[1]) for p, b in zip(ps, bounds, strict=True)])
        k = len(ps)
        stacked = [jw[0][j, :, :k] if len(jw) == 1 else
                   np.vstack([jr[j][:, :k] for jr in jw]) for jw in jacs]
        fitted, moved_ev = (laplace_evidence(float(cost[w, j]), stacked[w], z, zl, zu)[0]
                            for w in (0, 1))
        sd = _sandwich_sd(stacked[0].T @ stacked[0], spread[j, :k, :k])
        out.append((moved_ev - fitted - 0.5 * float(log_det[j]), sd,
                    [mg[j] for mg in marginal], float(cost[1, j])))
    return out
