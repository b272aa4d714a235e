"""Goodness of fit: does any hypothesis of the fault library explain the readings?

Probabilities compare the hypotheses with one another; they say nothing about whether
any of them fits.  With normalised residuals ``r_i = (y_i − ŷ_i(θ̂)) / σ_i`` of the best
fit, a hypothesis with ``k`` fitted parameters explains ``n`` readings when

.. math:: χ² = \\sum_i r_i^2 \\le χ²_{1-α}(ν), \\qquad ν = n - k \\ge 1

at the test level α = 1 % (the same test as the ambiguity set of
:mod:`diagnostics.isolability`) **and** its prior range holds: a fit pinned on a bound of
its range whose likelihood still rises past it is rejected by the range test of
:mod:`diagnostics.range_test` (the readings ask for a fault beyond the range, or for a
component better than the rig document says).  A hypothesis with as many parameters as
readings (ν ≤ 0: one parameter on the velocity ratio alone) fits any reading its range
can reach: it is rejected only where it cannot reach the readings (χ² above χ²_{1-α}(n):
the best fit's χ² is at most the χ² at the truth, a χ²_n variable, so this keeps the
level) or by the range test.  The readings are *explained*
when some observable hypothesis passes, tried in the order of their p-values (those with
ν ≤ 0 last); when the only ones that pass have ν ≤ 0 the result says that a misfit
cannot be detected with these readings (``testable`` false) instead of claiming a test.
When no observable hypothesis passes, the readings are
*not explained by the rig model and its fault library*: an unmodelled fault, a fault
beyond the prior ranges, a rig document that does not describe the rig, or a faulty
sensor.  The result then names the readings that disagree most with the best fit, in
standard uncertainties, and points to the discrepancy workflow (``hydrodiag discover``,
``POST /discrepancy``) and to commissioning (``POST /rigs/{id}/commission``,
``hydrodiag commission``) instead of naming a fault.  It states the factor on every
uncertainty at which the reported fit would pass (:func:`uncertainty_factor`; "noisier
instruments" up to :data:`NOISE_FACTOR`) and the unit mistakes — absolute pressures, °F —
that, undone, let a hypothesis explain the readings (:mod:`diagnostics.unit_mistakes`).

The covariance of the readings carries the stated load's and oil temperature's
uncertainty with the sensitivity of the *healthy* rig's readings
(:mod:`diagnostics.record_model`); a worn component's leakage makes the readings feel the
temperature many times more.  A one-parameter fit the test rejects is therefore tested
again with that sensitivity taken at its estimate
(:func:`diagnostics.condition_interval.check_singles`, computed once by
:func:`diagnostics.diagnose.diagnose` for this test and the ambiguity set), and passes if
that χ² does; the statement then gives both.  (Joint visits of a worn seal without flow
meters, each record's temperature stated within its thermometer's class, were "not
explained" in 5 of 30, with the true temperatures in none.)

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
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import numpy.typing as npt
from scipy.special import chdtrc, gammaincinv

from diagnostics.goodness_result import (
    NOISE_FACTOR,
    Disagreement,
    GoodnessOfFit,
    UnitMistake,
    uncertainty_factor,
)
from diagnostics.hypotheses import PARAMETERS
from diagnostics.range_test import RangeTest, pinned, range_test, range_tests
from diagnostics.ranking import HypothesisFit, Ranker
from sim.units import unit_suffix

__all__ = ["TEST_LEVEL", "Disagreement", "GoodnessOfFit", "chi2_limit", "goodness_of_fit",
           "stall_limit", "uncertainty_factor"]

#: test level α of the goodness-of-fit test [-]
TEST_LEVEL = 0.01

#: a reading is named as disagreeing beyond this many standard uncertainties [σ]
DISAGREE_SIGMA = 3.0


def _p_value(chi2: float, dof: int) -> float:
    # the χ² survival function as scipy.stats.chi2.sf computes it (its support χ² ≥ 0),
    # without the distribution object's per-call argument checks
    if not math.isfinite(chi2):
        return 0.0
    return float(chdtrc(dof, chi2)) if chi2 >= 0.0 else 1.0


def chi2_limit(level: float, dof: float) -> float:
    """χ²_{1−α}(ν) [-]: the limit of the χ² test at ``level`` α with ``dof`` ν."""
    # χ²_{1-α}(ν) as scipy.stats.chi2.ppf computes it: 2·P⁻¹(ν/2, 1 − α)
    return float(2.0 * gammaincinv(0.5 * dof, 1.0 - level))


def _disagreements(ranker: Ranker, fit: HypothesisFit,
                   sigma: Sequence[npt.NDArray[np.float64]] | None = None
                   ) -> list[Disagreement]:
    """The readings that disagree most with ``fit``, in σ of the readings (``sigma``, per
    record, where the test weighed them by another covariance than the ranking's)."""
    out = []
    for i, (m, pred) in enumerate(zip(ranker.models, fit.predicted, strict=True)):
        sig = m.sigma if sigma is None else sigma[i]
        for j, name in enumerate(m.obs.names):
            y, s = float(m.obs.values[j]), float(sig[j])
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


def _dof(ranker: Ranker, f: HypothesisFit) -> int:
    return ranker.n_obs - len(f.hypothesis.parameters)


def goodness_of_fit(ranker: Ranker, fits: list[HypothesisFit], level: float = TEST_LEVEL,
                    at_fit: Mapping[str, float] | None = None,
                    at_fit_sigma: Mapping[str, Sequence[npt.NDArray[np.float64]]] | None = None,
                    mistakes: Callable[[], list[UnitMistake]] | None = None
                    ) -> GoodnessOfFit:
    """χ² goodness of fit and range test of the observable hypotheses among ranked
    ``fits`` (module docstring); ``at_fit``: the χ² of one-parameter fits with the
    stated condition's sensitivity at their estimates, by name, and ``at_fit_sigma`` the
    readings' σ per record there, in which a fit explained by that χ² states its
    disagreeing readings (:func:`diagnostics.condition_interval.check_singles`);
    ``mistakes``, called only when nothing explains the readings: the mistakes in their
    units that, undone, would (:func:`diagnostics.unit_mistakes.unit_mistakes`)."""
    retest = at_fit or {}
    cands = [f for f in fits if f.observable] or fits[:1]
    scored = []
    for f in cands:
        dof = _dof(ranker, f)
        p = _p_value(f.chi2, dof) if dof >= 1 else (1.0 if math.isfinite(f.chi2) else 0.0)
        scored.append((dof >= 1, p, -f.probability, f, dof))
    scored.sort(key=lambda s: (not s[0], -s[1], s[2]))
    tests: list[RangeTest] = []
    passed = None
    used: dict[str, float] = {}
    for testable, p, _, f, dof in scored:
        # ν ≤ 0: the best fit's χ² is at most the χ² at the truth, a χ²_n variable, so
        # χ² > χ²_{1-α}(n) still rejects at level α (conservative): the reading lies
        # beyond what the hypothesis can reach
        lim = chi2_limit(level, dof) if testable else chi2_limit(level, ranker.n_obs)
        if (not math.isfinite(f.chi2) or f.chi2 > lim) and retest.get(f.name, math.inf) <= lim:
            used[f.name] = retest[f.name]
            p = _p_value(used[f.name], dof) if testable else p
        elif not math.isfinite(f.chi2) or f.chi2 > lim:
            continue
        rt = range_test(ranker, f, level) if f.parameters else None
        if rt is not None:
            tests.append(rt)
            if rt.rejected:
                continue
        passed = (testable, p, f, dof, rt if rt is not None and rt.incipient else None)
        break
    if passed is None:
        passed = _incipient_pass(ranker, scored, tests, level)
    explained = passed is not None
    incipient = None
    chi2 = math.nan
    if passed is not None:
        testable, p, best, dof, incipient = passed
        if incipient is None:
            chi2 = used.get(best.name, best.chi2)
        else:  # the χ² at the values between the document's and the worn range's start
            chi2 = incipient.chi2_document
            p = _p_value(chi2, dof) if dof >= 1 else p
    else:
        testable, p, _, best, dof = max(scored, key=lambda s: (s[0], s[1], -s[2]))
        chi2 = best.chi2
    limit = chi2_limit(level, dof) if dof >= 1 else math.inf
    factor = uncertainty_factor(chi2, limit if dof >= 1 else chi2_limit(level, ranker.n_obs))
    # a relief setting that cannot open anywhere in its prior is unobservable, yet one
    # below the prior's lowest can: readings nothing explains are tested for it too (a
    # relief at 0.2 × nominal read "relief_setting: not observable" and nothing beyond
    # range; an engineer's pass)
    below = [] if explained else [f for f in fits if not f.observable
                                  and f.name == "relief_setting"]
    beyond = _beyond_range(ranker, cands + below, tests, level)
    dis = _disagreements(ranker, best, (at_fit_sigma or {}).get(best.name)
                         if best.name in used else None)
    found: list[UnitMistake] = []
    if explained and testable:
        statement = (f"the readings are consistent with {best.name} (χ² = {chi2:.3g} on "
                     f"{dof} degrees of freedom, limit {limit:.3g} at the {level:.0%} level"
                     + (f"; with the stated load's and temperature's uncertainty taken at "
                        f"the fitted wear, where it weighs more than at the healthy rig's: "
                        f"{best.chi2:.3g} at the healthy rig's" if best.name in used
                        and incipient is None else "") + ")"
                     + _most_probable_clause(ranker, cands, best, retest, level))
    elif explained:
        statement = (
            f"a misfit cannot be detected with these readings: {best.name} has "
            f"{len(best.hypothesis.parameters)} parameter(s) for {ranker.n_obs} reading(s), "
            "so it fits any value its range reaches and no χ² test is possible (nor does a "
            "range test show a value beyond its prior); a fault outside the library "
            "or a rig document that does not describe this rig would not show — add a "
            "reading (a pressure, a flow) to test the fit")
    else:
        found = mistakes() if mistakes is not None else []
        statement = _misfit_statement(ranker, cands, best, dof, limit, level, dis, tests,
                                      factor, found)
    if incipient is not None:
        statement += _incipient_clause(ranker, incipient)
    if beyond:
        statement += (
            (" " if statement.endswith(".") else ". ")
            + ("The readings are explained as well by a fault beyond the library's prior "
               "range: " if explained else "A fault beyond the library's prior range "
               "explains them: ") + "; ".join(
                f"{t.hypothesis} at " + ", ".join(f"{k} = {v:.4g}{unit_suffix(PARAMETERS[k].unit)}"
                                                    for k, v in t.extended.items())
                + f" (χ² = {t.chi2_extended:.3g})" for t in beyond)
            + (f"; {max(cands, key=lambda f: f.probability).name} is not a confident "
               "answer" if explained else "") + ": check "
            + " and ".join(sorted({c for t in beyond for c in _components(t)}))
            + " directly.")
    return GoodnessOfFit(best.name, float(chi2), max(dof, 0), level, limit, p,
                         explained, dis, statement, bool(testable or not explained), tests,
                         beyond, incipient, factor, found)


def _most_probable_clause(ranker: Ranker, cands: list[HypothesisFit], best: HypothesisFit,
                          retest: Mapping[str, float], level: float) -> str:
    """The statement's clause on the most probable fit when the test names another (the
    one the readings fit best by the χ² test's p-value, which a simpler or a more probable
    hypothesis need not be): whether it passes the same test, so that a reader of the
    answer's top name is not left to guess."""
    top = max(cands, key=lambda f: f.probability)
    if top is best:
        return ""
    dof = _dof(ranker, top)
    if dof < 1:
        return (f"; the most probable, {top.name}, has as many parameters as readings: "
                "the test cannot judge it")
    lim = chi2_limit(level, dof)
    chi2 = min(top.chi2, retest.get(top.name, math.inf))
    verdict = "passes it too" if chi2 <= lim else "does not pass it"
    return (f"; the most probable, {top.name}, {verdict} (χ² = {chi2:.3g} on {dof} degrees "
            f"of freedom, limit {lim:.3g})")


def _incipient_pass(ranker: Ranker, scored: list[tuple[bool, float, float, HypothesisFit,
                                                      int]],
                    tests: list[RangeTest], level: float
                    ) -> tuple[bool, float, HypothesisFit, int, RangeTest] | None:
    """When no hypothesis passes: the first (in the order tried) whose fit sits on the
    healthy end of its worn range and whose χ² with the values its range test finds
    between the rig document's and that end passes the test — incipient wear, or a
    rig document off by that much (:func:`diagnostics.range_test._incipient`).  Range
    tests run here are added to ``tests``."""
    done = {t.hypothesis: t for t in tests}
    for testable, p, _, f, dof in scored:
        if not f.parameters or not any(side == "healthy" for _, side in pinned(ranker, f)):
            continue
        rt = done.get(f.name)
        if rt is None:
            rt = range_test(ranker, f, level)
            if rt is None:
                continue
            tests.append(rt)
        if rt.rejected or not rt.incipient:
            continue
        chi2 = rt.chi2_document
        lim = chi2_limit(level, dof) if testable else chi2_limit(level, ranker.n_obs)
        if chi2 <= lim:
            return testable, p, f, dof, rt
    return None


def _incipient_clause(ranker: Ranker, rt: RangeTest) -> str:
    """The statement's clause on values below the worn range (:attr:`GoodnessOfFit.
    incipient`)."""
    parts = []
    for name, value in rt.incipient.items():
        par = PARAMETERS[name]
        worn = par.worn_bounds(ranker.rig)[0]
        unit = "" if par.unit == "1" else f" {par.unit}"
        parts.append(f"{name} = {value:.4g}{unit} (the rig document {par.nominal_value(ranker.rig):.4g}"
                     f"{unit}, the worn range from {worn:.4g}{unit})")
    comps = sorted({PARAMETERS[n].component for n in rt.incipient})
    return (f", with {' and '.join(parts)} below the worn range: incipient wear of the "
            f"{' and '.join(comps)}, or a rig document off by that much; not a confident "
            "name: watch the trend, and commission a new or rebuilt rig from healthy "
            "records (`hydrodiag commission`, POST /rigs/{id}/commission)")


def _components(t: RangeTest) -> set[str]:
    return {PARAMETERS[p].component for p in t.parameters}


def _beyond_range(ranker: Ranker, cands: list[HypothesisFit], tests: list[RangeTest],
                  level: float) -> list[RangeTest]:
    """Single-fault explanations beyond the prior ranges (:attr:`GoodnessOfFit.
    beyond_range`); each range test is run once (those already in ``tests`` reused)."""
    done = {t.hypothesis: t for t in tests}
    todo = [f for f in cands if len(f.parameters) == 1 and f.name not in done
            and any(side == "severe" for _, side in pinned(ranker, f))]
    for rt in range_tests(ranker, todo, level):  # run together: one search for all
        if rt is not None:
            tests.append(rt)
            done[rt.hypothesis] = rt
    out = []
    for f in cands:
        rt = done.get(f.name)
        if rt is None or len(f.parameters) != 1 or not any(
                side == "severe" for _, side in pinned(ranker, f)):
            continue
        if not (rt.rejected and rt.sides == ["severe"]):
            continue
        dof = _dof(ranker, f)
        if rt.chi2_extended <= chi2_limit(level, dof if dof >= 1 else ranker.n_obs):
            out.append(rt)
    return out


def _misfit_statement(ranker: Ranker, cands: list[HypothesisFit], best: HypothesisFit,
                      dof: int, limit: float, level: float, dis: list[Disagreement],
                      tests: list[RangeTest], factor: float | None,
                      mistakes: list[UnitMistake]) -> str:
    """The statement of readings not explained (names the disagreeing readings, the
    mistakes in their units that, undone, explain them, the range tests that failed, the
    common factor on the uncertainties at which the best fit would pass where noise could
    be the cause, and the next steps)."""
    worst = ", ".join(
        (f"{d.reading}" + (f" (record {d.record})" if len(ranker.models) > 1 else "")
         + (f" by {d.deviation:+.1f} σ" if math.isfinite(d.deviation) else
            " (the model has no value: the piston stalls)"))
        for d in dis[:4])
    fit_clause = (f"even the best fit ({best.name}) leaves χ² = {best.chi2:.3g} on {dof} "
                  f"degrees of freedom (limit {limit:.3g} at the {level:.0%} level)"
                  if dof >= 1 else
                  f"even the best fit ({best.name}, as many parameters as readings) leaves "
                  f"χ² = {best.chi2:.3g} (limit {chi2_limit(level, ranker.n_obs):.3g} on "
                  f"{ranker.n_obs} reading(s) at the {level:.0%} level)")
    statement = (
        "the readings are not explained by the rig model and its fault library: "
        f"{fit_clause}; disagreeing readings: {worst}.")
    if mistakes:
        statement += " Likely: " + "; ".join(m.statement for m in mistakes) + "."
    rejected = [t for t in tests if t.rejected]
    if rejected:
        statement += (" Fits pinned on a bound of their prior whose likelihood still rises "
                      "past it (a fault beyond the prior, but none explains the readings "
                      "either): ") + "; ".join(
            t.describe() for t in rejected) + "."
    statement += (
        " No fault is named. Possible causes: a stated condition that is wrong (an oil "
        "temperature in °F or of another sensor, a load in another unit), a fault outside "
        "the library or beyond its prior ranges, a rig document that does not describe "
        "this rig, or a faulty sensor"
        + (f"; or instruments that scatter more than their stated uncertainties: the best "
           f"fit would pass were every uncertainty {factor:.2f}× the stated one (readings, "
           "stated load and temperature, model) — if the instruments are that much less "
           "precise than their class, state each reading's `u` or `bound`"
           if factor is not None and 1.0 < factor <= NOISE_FACTOR else "")
        + ". Next steps: the discrepancy workflow (`hydrodiag "
        "discover`, POST /discrepancy) and commissioning the rig from healthy records "
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
    return statement
