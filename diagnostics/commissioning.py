"""Commissioning: fit a new rig's uncertain parameters from a few healthy records.

A rig document states some parameters that nobody measured: the sealing lengths of the
piston (``cylinder.Lc``) and of the spool lands (``valve.Ls``), the valve's flow
coefficient ``valve.K``, the seal friction ``cylinder.Fu`` and ``cylinder.Kf``, the pump's
leakage resistance ``pump.Rlp``.  Records of the rig *as built* (healthy, clearances
nominal) at several loads and oil temperatures pin them down.

Model: each parameter is fitted in ``z = ln(θ/θ₀)`` (θ₀ the document's value) with a
Gaussian prior ``z ~ N(0, s²)`` — ``s`` the stated relative uncertainty of the value
(:data:`PRIOR_SD`) — and the readings' likelihood of the diagnosis
(:mod:`diagnostics.record_model`: ``r = W (y − ŷ(θ))``, ``WᵀW = C⁻¹``, C the instruments'
variances, a model term ``model_rel·ŷ`` and the correlated terms of the record's stated
oil temperature and load, taken at the document's values).  Levenberg-Marquardt
(:func:`diagnostics.prior_fit.fit_with_prior`) on the steady operating points
(:class:`sim.steady.SteadyEvaluator`) minimises

.. math:: Φ(z) = \\sum_i r_i(z)^2 + \\sum_j (z_j / s_j)^2

and the Laplace approximation gives the posterior covariance
``C = (JᵀJ + diag(1/s²))⁻¹`` (J the Jacobian of the normalised residuals in z); the 95 %
interval of θ_j is ``θ₀·exp(ẑ_j ± 1.96·√C_jj)`` — for a pinned parameter with the
parameters the records leave open integrated over their posterior rather than
linearised (:mod:`diagnostics.commissioning_nuisance`: Fu takes up the open Kf's error
through Fu + Kf·v, and its linearised interval held the truth in 88 % of seeds).

Identifiability: a parameter is *pinned down* when the records shrink its prior standard
deviation at least by half (``√C_jj ≤ 0.5·s_j``); otherwise the result says the records
could not pin it down, keeps the prior's interval, and names the parameters it trades
off against (posterior correlation |ρ| ≥ 0.8), with a hint at the records that would
separate them (another load or temperature, the flow meters).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt

from diagnostics.commissioning_nuisance import marginal_intervals
from diagnostics.commissioning_result import PRIOR_LIMIT, CommissionedParameter, Commissioning
from diagnostics.evidence import whitening
from diagnostics.goodness import DISAGREE_SIGMA, TEST_LEVEL, chi2_limit
from diagnostics.measurement import MeasurementRecord
from diagnostics.observations import RecordObservations, observe
from diagnostics.prior_fit import fit_with_prior
from diagnostics.record_model import condition_moves, condition_terms
from diagnostics.shared_errors import visit_covariance
from diagnostics.signatures import OBSERVABLES
from sim.errors import MeasurementError, SimulationError
from sim.rigs import Rig
from sim.steady import SteadyEvaluator
from sim.units import unit_suffix

__all__ = ["COMMISSIONED", "PRIOR_LIMIT", "PRIOR_SD", "CommissionedParameter", "Commissioning",
           "commission"]

Arr = npt.NDArray[np.float64]

#: parameters commissioning fits, with their meaning
COMMISSIONED: dict[str, str] = {
    "cylinder.Lc": "sealing length of the piston",
    "valve.Ls": "sealing length of the spool lands",
    "valve.K": "flow coefficient of the valve's open paths",
    "cylinder.Fu": "Coulomb (seal) friction force",
    "cylinder.Kf": "viscous friction coefficient",
    "pump.Rlp": "internal leakage resistance of the pump",
}

#: which records separate a parameter from the others: the friction Fu + Kf·v only through
#: the piston's speed, the open paths' Δp ∝ Q²/K² through the flow (both set by the pump's
#: speed, not by the load or the oil: "other loads and oil temperatures" was advised for
#: Fu and Kf, a rig author's pass); the leaks, ∝ Δp/μ (paper 002 eqs. 19, 29), through
#: the load and the oil temperature
_FRICTION_HELP = ("at other pump speeds (friction Fu + Kf·v separates through the piston "
                  "speed only)")
HELPS: dict[str, str] = {
    "cylinder.Fu": _FRICTION_HELP,
    "cylinder.Kf": _FRICTION_HELP,
    "valve.K": "at other pump speeds (the open paths' pressure drop grows with the flow)",
}
HELPS_LEAK = "at other loads and oil temperatures (the leaks grow with Δp/μ)"

#: prior standard deviation of ln(θ/θ₀) [-]: how far an unmeasured value may be off
#: (0.5 ≈ a factor 1.65 at 1 σ: values chosen or read from damaged figures)
PRIOR_SD: dict[str, float] = {"cylinder.Lc": 0.5, "valve.Ls": 0.5, "valve.K": 0.7,
                              "cylinder.Fu": 0.5, "cylinder.Kf": 0.7, "pump.Rlp": 0.7}

#: a fit's χ² below its quantile at this level is said: records fitting better than their
#: noise allows (copies of one record) [-]
TOO_GOOD = 1e-4
#: a stored value beyond this many prior σ of ln θ from the document's is said [-]
PRIOR_NOTE = 2.0
#: a parameter is pinned down when the records shrink its prior σ by this factor [-]
PINNED = 0.5


class _Problem:
    """Whitened residuals of all records for log-parameters ``z``.

    Each record's readings are weighed as the diagnosis weighs them
    (:mod:`diagnostics.record_model`): ``C = diag(u² + (ρ·ŷ₀)²) + Σ_k s_k s_kᵀ u_k²`` with
    ``ŷ₀`` the readings at the document's values and ``s_k`` their sensitivity to the
    record's stated oil temperature and load (one thermometer or load-cell error moves
    every reading of the record at once), whitened by ``W`` (``WᵀW = C⁻¹``).  Treating a
    stated condition as exact made the readings disagree by more than their σ and the
    95 % intervals hold the truth in 83.8 % of (seed, parameter) pairs of ``make
    accuracy``'s commissioning suite, whose records state their condition with their
    instruments' error (96.4 % weighed so).
    """

    def __init__(self, rig: Rig, obs: list[RecordObservations], names: tuple[str, ...],
                 model_rel: float) -> None:
        self.names = names
        self.theta0 = np.array([rig.base[n] for n in names])
        self.obs = obs
        self.evs = [SteadyEvaluator(rig, o.condition, names) for o in obs]
        self.idx = [np.array([OBSERVABLES.index(n) for n in o.names]) for o in obs]
        self.model_rel = model_rel
        parts = [self._covariance(rig, ev, o, idx)
                 for ev, o, idx in zip(self.evs, obs, self.idx, strict=True)]
        self.weights = [whitening(diag, terms) for diag, terms in parts]
        # records read by the same instruments: the visit's whole covariance
        # (:mod:`diagnostics.shared_errors`), else each record's own
        stacked = visit_covariance(obs, [d for d, _ in parts], [t for _, t in parts])
        self.visit = None if stacked is None else whitening(*stacked)[1]
        for i, (o, (sigma, _)) in enumerate(zip(obs, self.weights, strict=True)):
            for name, value, sig in zip(o.names, o.values, sigma, strict=True):
                if not sig > 0.0:
                    # as /diagnose says it (record_model): a stalled stroke's speed stated
                    # with u = 0 read "χ² = nan … speed_work by +inf σ — a record of a worn
                    # component" (an engineer's pass)
                    raise MeasurementError(
                        f"the reading {float(value):g} has zero standard uncertainty (its "
                        "stated u is 0 and nothing else is uncertain here); a stroke that "
                        "does not move has no speed or velocity ratio to read: leave the "
                        "reading out, or state its uncertainty", field=f"records[{i}].{name}")

    def _covariance(self, rig: Rig, ev: SteadyEvaluator, o: RecordObservations, idx: Arr
                    ) -> tuple[Arr, list[Arr]]:
        """(independent variances, condition terms) of one record's covariance (class
        docstring) [SI², SI]."""
        pred = ev.vector(self.theta0, OBSERVABLES)[idx]
        rel = self.model_rel * pred
        diag = o.u**2 + np.where(np.isfinite(rel), rel, 0.0) ** 2
        terms = condition_terms(pred, condition_moves(o), lambda c: SteadyEvaluator(
            rig, c, self.names).vector(self.theta0, OBSERVABLES)[idx])
        return diag, terms

    def residuals(self, z: Arr) -> Arr:
        theta = self.theta0 * np.exp(z)
        if self.visit is not None:
            whole = np.concatenate([o.values - ev.vector(theta, OBSERVABLES)[idx]
                                    for ev, o, idx in zip(self.evs, self.obs, self.idx,
                                                          strict=True)])
            if np.all(np.isfinite(whole)):
                return np.asarray(self.visit @ whole)
        out = []
        for ev, o, idx, (sigma, white) in zip(self.evs, self.obs, self.idx, self.weights,
                                              strict=True):
            resid = o.values - ev.vector(theta, OBSERVABLES)[idx]
            if np.all(np.isfinite(resid)):
                out.append(white @ resid)
            else:  # a reading the model cannot produce there: its marginal σ, 1e3 if none
                r = resid / sigma
                out.append(np.where(np.isfinite(r), r, 1e3))
        return np.concatenate(out)


def commission(rig: Rig, records: Sequence[MeasurementRecord],
               parameters: Sequence[str] | None = None, *, model_rel: float = 0.002,
               max_iterations: int = 30, origin: Mapping[str, float] | None = None
               ) -> Commissioning:
    """Fit the uncertain parameters of ``rig`` to healthy ``records`` (module docstring).

    Parameters
    ----------
    rig
        The rig as documented (clearances at their as-built values).
    records
        Records of the healthy rig, ideally at several loads and oil temperatures.
    parameters
        Which of :data:`COMMISSIONED` to fit (all by default).
    model_rel
        Relative model uncertainty added to every reading [-].
    max_iterations
        Levenberg-Marquardt iteration limit [-].
    origin
        Each parameter's value before any commissioning [SI] (the document as its author
        wrote it), where ``rig`` was commissioned before: the shift the guard measures is
        from it, not from the last fit (a second commissioning from a worn seal's records
        took Lc 7.93 → 2.13 mm, where from the author's 10 mm it is refused: a
        commissioning engineer's pass).

    Raises
    ------
    MeasurementError
        No records, a record impossible on the rig, or an unknown parameter name.
    CircuitError
        The rig's circuit has no cylinder cycle.
    """
    rig.require_cycle("commissioning")
    if not records:
        raise MeasurementError("at least one healthy record is needed", field="records")
    names = tuple(parameters) if parameters is not None else tuple(COMMISSIONED)
    for i, n in enumerate(names):
        if n not in COMMISSIONED:
            raise MeasurementError(f"cannot commission {n!r}; one of {', '.join(COMMISSIONED)}",
                                   field=f"parameters[{i}]")
    if len(set(names)) != len(names):
        raise MeasurementError("a parameter is named twice", field="parameters")
    _refuse_repeats(records)
    obs = []
    for i, rec in enumerate(records):
        try:
            obs.append(observe(rec, rig))
        except MeasurementError as exc:
            raise MeasurementError(exc.message, field=".".join(
                x for x in (f"records[{i}]", exc.field or "") if x)) from None
    # every record with both flow meters: advice to fit them would be empty (a user pass)
    metered = all(rec.flow_B is not None and rec.flow_C is not None for rec in records)
    try:
        problem = _Problem(rig, obs, names, model_rel)
        z, r, jac, its = fit_with_prior(problem.residuals, np.array([PRIOR_SD[n] for n in names]),
                                        np.zeros(len(names)), max_iterations=max_iterations)
    except SimulationError as exc:
        raise MeasurementError(f"the rig has no steady operating point at a record's "
                               f"condition: {exc}", field="records") from None
    s = np.array([PRIOR_SD[n] for n in names])
    cov = np.linalg.inv(jac.T @ jac + np.diag(1.0 / s**2))
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    corr = cov / np.outer(sd, sd)
    pins = [bool(sd[j] <= PINNED * s[j]) for j in range(len(names))]
    try:  # the open parameters integrated into the pinned ones' intervals
        bounds = marginal_intervals(problem.residuals, z, s, np.asarray(cov, dtype=float), pins,
                                    max_iterations=max_iterations)
    except SimulationError:
        bounds = {}
    out, statements = [], []
    for j, n in enumerate(names):
        pinned = pins[j]
        low, high = bounds.get(j, (z[j] - 1.96 * sd[j], z[j] + 1.96 * sd[j]))
        partners = [names[k] for k in range(len(names))
                    if k != j and abs(corr[j, k]) >= 0.8]
        theta0 = float(problem.theta0[j])
        first = float((origin or {}).get(n, theta0))
        moved = z[j] + math.log(theta0 / first)     # from the value before commissioning
        shift = float(moved / s[j])
        out.append(CommissionedParameter(
            n, COMMISSIONED[n], theta0, theta0 * math.exp(z[j]),
            theta0 * math.exp(low), theta0 * math.exp(high),
            float(s[j]), float(sd[j]), pinned, partners, shift))
        role, key = n.split(".")
        decl = rig.circuit.parameter(role, key)
        unit = unit_suffix(decl.unit) if decl is not None else ""
        since = ("" if first == theta0 else
                 f" as its author wrote it ({first:.4g}{unit}; commissioned since to "
                 f"{theta0:.4g}{unit})")
        if abs(shift) > PRIOR_LIMIT:
            statements.append(
                f"{n} ({COMMISSIONED[n]}) moved {math.expm1(moved):+.0%} from the document's "
                f"value{since}, {abs(shift):.1f} prior σ: more than the document's "
                f"uncertainty (±{s[j]:.2f} in ln θ) allows. The records may hold wear the fit "
                "absorbed (a worn valve's leak read as a short land; diagnose them first), "
                "or the document's value is wrong" + _as_wear(n, moved))
        elif pinned and abs(shift) > PRIOR_NOTE:
            # a seal worn to 1.5× its clearance was stored as Lc −74 % without a word, and
            # the worn seal then diagnosed "healthy" (a commissioning engineer's pass)
            statements.append(
                f"{n} ({COMMISSIONED[n]}) moved {math.expm1(moved):+.0%} from the document's "
                f"value{since}, {abs(shift):.1f} prior σ: stored, but check that the records "
                "are of a healthy rig (diagnose them against the document first)"
                + _as_wear(n, moved))
        if not pinned:
            # "hardly depend on it" beside ±0.70 → ±0.36 read as a contradiction (a user
            # pass): said only where the records left most of the prior's uncertainty
            why = (f"it trades off against {', '.join(partners)}" if partners else
                   "the readings hardly depend on it at these conditions"
                   if sd[j] > 0.8 * s[j] else
                   f"the readings feel it, but not enough to bring its uncertainty to "
                   f"{PINNED:.0%} of the document's")
            statements.append(
                f"{n} ({COMMISSIONED[n]}): not pinned down by these records — its uncertainty "
                f"shrank only from ±{s[j]:.2f} to ±{sd[j]:.2f} in ln θ; {why}. The document's "
                f"value is kept; records {HELPS.get(n, HELPS_LEAK)}"
                + ("" if metered else ", or with the flow meters,") + " would help")
    chi2 = float(r @ r)
    # degrees of freedom: the readings less the parameters the records determine, each
    # counting 1 − posterior/prior variance — their sum, tr(JᵀJ·C), is MacKay's number of
    # well-determined parameters γ (MacKay 1992, Neural Comput. 4:415, §4), so that
    # χ² ≈ n − γ for a model that fits
    dof = float(r.size - np.sum(1.0 - (sd / s) ** 2))
    limit = chi2_limit(TEST_LEVEL, dof) if dof > 0 else math.inf
    if dof >= 5 and chi2 < chi2_limit(1.0 - TOO_GOOD, dof):
        # one record sent six times, each rounded differently, fitted at χ² 1.2 on 37 and
        # stored Rlp 41 % off without a word (a commissioning engineer's pass)
        statements.append(
            f"the records fit far better than their stated uncertainties allow (χ² = "
            f"{chi2:.3g} on {dof:.1f} degrees of freedom, below its {TOO_GOOD:.0e} quantile "
            f"{chi2_limit(1.0 - TOO_GOOD, dof):.3g}): copies of one record, or uncertainties "
            "stated too wide; the intervals are narrower than the records justify")
    disagreements = _disagreements(problem, z)
    consistent = chi2 <= limit
    if not consistent:
        worst = ", ".join(f"records[{i}].{name} by {dev:+.1f} σ"
                          for i, name, dev in disagreements[:4])
        statements.insert(0, (
            f"the records are not those of one healthy rig of this document: at the fit χ² = "
            f"{chi2:.4g} on {dof:.1f} degrees of freedom (limit {limit:.4g} at the "
            f"{TEST_LEVEL:.0%} level); the readings that disagree most: {worst} — a record of "
            "a worn component, a record at another condition than it states, or an effect "
            "the rig model lacks; leave such a record out (or diagnose it) and commission "
            "again"))
    return Commissioning(rig.spec.name, out, chi2, int(r.size), len(records), its, statements,
                         dof, limit, consistent, disagreements)


def _as_wear(name: str, moved: float) -> str:
    """The wear a leakage parameter's move ``moved`` (of ln θ) stands for: a shorter seal
    land leaks as a wider clearance, Q ∝ c³/L (paper 002 eqs. 23, 36), a lower pump
    resistance as a larger pump leak, Q = p/Rlp (eq. 5)."""
    if name in ("cylinder.Lc", "valve.Ls") and moved < 0:
        part = "seal" if name == "cylinder.Lc" else "spool"
        return (f"; as leakage it reads as the {part} at {math.exp(-moved / 3):.2f}× its "
                f"clearance (leak ×{math.exp(-moved):.2f}, Q ∝ c³/L)")
    if name == "pump.Rlp" and moved < 0:
        return f"; as leakage it reads as the pump's leak ×{math.exp(-moved):.2f} (Q = p/Rlp)"
    return ""


def _refuse_repeats(records: Sequence[MeasurementRecord]) -> None:
    """Refuse a record whose condition and readings repeat an earlier one's: six copies of
    one record fitted as six, narrowed the intervals until they missed the truth (Rlp
    −41 %) and called Ls pinned down (a commissioning engineer's pass); real readings are
    never equal to the last digit."""
    seen: dict[Any, int] = {}
    for i, rec in enumerate(records):
        key = replace(rec, taken_at=None, rig_name=None)
        try:
            first = seen.setdefault(key, i)
        except TypeError:     # unhashable: compare one by one
            first = next((k for k, v in seen.items() if v == key), i)
        if first != i:
            raise MeasurementError(f"records[{i}] repeats records[{first}]'s condition and "
                                   "readings: each record counts as new evidence, so send it "
                                   "once", field=f"records[{i}]")


def _disagreements(problem: _Problem, z: Arr) -> list[tuple[int, str, float]]:
    """(record index, reading, (y − ŷ)/σ) at the fit ``z``, beyond
    :data:`DISAGREE_SIGMA` σ (σ the reading's marginal uncertainty), worst first."""
    theta = problem.theta0 * np.exp(z)
    out = []
    for i, (ev, o, idx, (sigma, _)) in enumerate(zip(problem.evs, problem.obs, problem.idx,
                                                     problem.weights, strict=True)):
        dev = (o.values - ev.vector(theta, OBSERVABLES)[idx]) / sigma
        out += [(i, name, float(d) if math.isfinite(d) else math.inf)
                for name, d in zip(o.names, dev, strict=True)
                if not abs(d) <= DISAGREE_SIGMA]
    return sorted(out, key=lambda x: -abs(x[2]))
