"""Goodness of fit: does any hypothesis of the fault library explain the readings?

Probabilities compare the hypotheses with one another; they say nothing about whether
any of them fits.  With normalised residuals ``r_i = (y_i − ŷ_i(θ̂)) / σ_i`` of the best
fit, a hypothesis with ``k`` fitted parameters explains ``n`` readings when

.. math:: χ² = \\sum_i r_i^2 \\le χ²_{1-α}(ν), \\qquad ν = \\max(n - k, 1)

at the test level α = 1 % (the same test as the ambiguity set of
:mod:`diagnostics.isolability`).  When no observable hypothesis passes, the readings are
*not explained by the rig model and its fault library*: an unmodelled fault, a fault
beyond the prior ranges, a rig document that does not describe the rig, or a faulty
sensor.  The result then names the readings that disagree most with the best fit, in
standard uncertainties, and points to the discrepancy workflow (``hydrodiag discover``,
``POST /discrepancy``) and to commissioning (``POST /rigs/{id}/commission``,
``hydrodiag commission``) instead of naming a fault.

Stalled strokes are fitted like any other.  Where the load is more than the (worn) rig
can push, the piston sits on its end stop, where the pump's flow goes through the leakage
paths and over the relief valve; the steady model has that end-stop state
(:mod:`sim.steady`, *End stops*) and the signature maps and fits predict it (speed 0), so
the leak sizes are estimated from a stalled record's pressures and flows.  Only when
even that does not explain the readings of a record that shows no working motion (no
working speed, or one within 3 σ of zero) while the most probable fit holds its piston
on the stop too does the statement add a model limit (:func:`stall_limit`): the stalled
rig is not described by the rig model's end-stop state and its fault library (a load or
relief setting off its stated value, a fault beyond the library); repeat the test at a
lower load or oil temperature, where the piston moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from scipy.special import chdtrc, gammaincinv

from diagnostics.ranking import HypothesisFit, Ranker

__all__ = ["TEST_LEVEL", "Disagreement", "GoodnessOfFit", "goodness_of_fit", "stall_limit"]

#: test level α of the goodness-of-fit test [-]
TEST_LEVEL = 0.01

#: a reading is named as disagreeing beyond this many standard uncertainties [σ]
DISAGREE_SIGMA = 3.0


@dataclass
class Disagreement:
    """One reading against the best fit.

    Attributes
    ----------
    record
        Index of the record in the request [-].
    reading
        Observable name (a :class:`~diagnostics.measurement.MeasurementRecord` field).
    measured, predicted
        Reading and the best fit's prediction [SI unit of the reading]; ``predicted`` is
        NaN where the model has no prediction (a stalled stroke).
    sigma
        Standard uncertainty used in the likelihood [SI unit of the reading].
    deviation
        (measured − predicted) / σ [σ].
    """

    record: int
    reading: str
    measured: float
    predicted: float
    sigma: float
    deviation: float


@dataclass
class GoodnessOfFit:
    """χ² test of the best-fitting observable hypothesis.

    Attributes
    ----------
    hypothesis
        The hypothesis tested (the observable one with the highest p-value).
    chi2
        Its χ² at the estimate [-].
    dof
        Degrees of freedom ν = max(n − k, 1) [-].
    level
        Test level α [-].
    limit
        χ²_{1-α}(ν) [-].
    p_value
        P(χ²_ν ≥ χ²) [-].
    explained
        Whether some observable hypothesis passes the test.
    disagreements
        Readings of the tested fit beyond 3 σ, worst first (the worst three when none is).
    statement
        One sentence for a reader.
    """

    hypothesis: str
    chi2: float
    dof: int
    level: float
    limit: float
    p_value: float
    explained: bool
    disagreements: list[Disagreement] = field(default_factory=list)
    statement: str = ""


def _p_value(chi2: float, dof: int) -> float:
    # the χ² survival function as scipy.stats.chi2.sf computes it (its support χ² ≥ 0),
    # without the distribution object's per-call argument checks
    if not math.isfinite(chi2):
        return 0.0
    return float(chdtrc(dof, chi2)) if chi2 >= 0.0 else 1.0


def _limit(level: float, dof: int) -> float:
    # χ²_{1-α}(ν) as scipy.stats.chi2.ppf computes it: 2·P⁻¹(ν/2, 1 − α)
    return float(2.0 * gammaincinv(0.5 * dof, 1.0 - level))


def _disagreements(ranker: Ranker, fit: HypothesisFit) -> list[Disagreement]:
    out = []
    for i, (m, pred) in enumerate(zip(ranker.models, fit.predicted, strict=True)):
        for j, name in enumerate(m.obs.names):
            y, s = float(m.obs.values[j]), float(m.sigma[j])
            yhat = float(pred[name])
            dev = (y - yhat) / s if math.isfinite(yhat) else math.inf
            out.append(Disagreement(i, name, y, yhat, s, dev))
    out.sort(key=lambda d: -abs(d.deviation))
    far = [d for d in out if abs(d.deviation) > DISAGREE_SIGMA]
    return far if far else out[:3]


def stall_limit(ranker: Ranker, fit: HypothesisFit) -> list[int]:
    """Records that show a stalled piston the end-stop state does not explain (module
    docstring): ``fit`` holds the piston on its end stop there (predicted working speed
    0) and the record shows no working motion (no working speed, or one within
    :data:`DISAGREE_SIGMA` standard uncertainties of zero).  Called when the fit is not
    explained."""
    out = []
    for i, (m, pred) in enumerate(zip(ranker.models, fit.predicted, strict=True)):
        v = float(pred.get("speed_work", math.nan))
        if v != 0.0:
            continue
        names = list(m.obs.names)
        if "speed_work" in names:
            j = names.index("speed_work")
            if abs(float(m.obs.values[j])) > DISAGREE_SIGMA * float(m.sigma[j]):
                continue
        out.append(i)
    return out


def goodness_of_fit(ranker: Ranker, fits: list[HypothesisFit], level: float = TEST_LEVEL
                    ) -> GoodnessOfFit:
    """χ² goodness of fit of the best observable hypothesis among ranked ``fits``."""
    n = ranker.n_obs
    cands = [f for f in fits if f.observable] or fits[:1]
    scored = []
    for f in cands:
        dof = max(n - len(f.hypothesis.parameters), 1)
        scored.append((_p_value(f.chi2, dof), -f.probability, f, dof))
    p, _, best, dof = max(scored, key=lambda s: (s[0], s[1]))
    limit = _limit(level, dof)
    explained = bool(math.isfinite(best.chi2) and best.chi2 <= limit)
    dis = _disagreements(ranker, best)
    if explained:
        statement = (f"the readings are consistent with {best.name} (χ² = {best.chi2:.3g} on "
                     f"{dof} degrees of freedom, limit {limit:.3g} at the {level:.0%} level)")
    else:
        worst = ", ".join(
            (f"{d.reading}" + (f" (record {d.record})" if len(ranker.models) > 1 else "")
             + (f" by {d.deviation:+.1f} σ" if math.isfinite(d.deviation) else
                " (the model has no value: the piston stalls)"))
            for d in dis[:4])
        statement = (
            "the readings are not explained by the rig model and its fault library: even the "
            f"best fit ({best.name}) leaves χ² = {best.chi2:.3g} on {dof} degrees of freedom "
            f"(limit {limit:.3g} at the {level:.0%} level); disagreeing readings: {worst}. "
            "No fault is named. Possible causes: a fault outside the library or beyond its "
            "prior ranges, a rig document that does not describe this rig, or a faulty "
            "sensor. Next steps: the discrepancy workflow (`hydrodiag discover`, "
            "POST /discrepancy) and commissioning the rig from healthy records "
            "(`hydrodiag commission`, POST /rigs/{id}/commission).")
        stalled = stall_limit(ranker, max(cands, key=lambda f: f.probability))
        if stalled:
            which = "" if len(ranker.models) == 1 else \
                " (records " + ", ".join(map(str, stalled)) + ")"
            statement += (
                f" Model limit{which}: the record shows no working motion and the most "
                "probable fit holds the piston on its end stop too, yet the readings of "
                "that stalled state (the pump's flow through the leakage paths and over "
                "the relief valve) are not those of the rig model and its fault library; "
                "repeat the test at a lower load or oil temperature, where the piston "
                "moves.")
    return GoodnessOfFit(best.name, float(best.chi2), dof, level, limit, p, explained, dis,
                         statement)

