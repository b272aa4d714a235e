"""The result of :func:`diagnostics.diagnose.diagnose`: the ranked hypotheses, what the
sensors cannot separate, the closed-form inversions and the goodness of fit, with the plain
(JSON-able, SI) form the service answers with."""

from __future__ import annotations

from dataclasses import dataclass, field, fields, is_dataclass
from typing import Any

from diagnostics.goodness import GoodnessOfFit
from diagnostics.isolability import Isolability
from diagnostics.observations import OBSERVABLE_UNITS
from diagnostics.ranking import MULTIPLE_OF, HypothesisFit, ParameterEstimate
from diagnostics.ratio_index import RatioIndex
from diagnostics.uncertainty import Estimate

__all__ = ["BLIND_NOTE", "Diagnosis", "plain"]


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    rig
        Rig name.
    hypotheses
        All hypotheses, most probable first (unobservable ones last, probability 0).
    isolability
        What the sensors cannot separate and what would.
    direct
        Closed-form equivalent clearances (``"cc"``, ``"cv"``) of paper 002 §2.7, with
        intervals: of the record whose inversion is the most precise (least standard
        uncertainty) among those that allow them.
    ratio
        Ratio index, when a record has a velocity ratio but not both speeds (of the
        record whose ratio is the most precise).
    pump_slip
        Laminar slip coefficient Cs [-] equivalent to the pump hypothesis's leakage
        (paper 000 eq. 6: Q_slip = Cs·D·Δp/μ, D per radian) at the records' mean oil
        temperature, with its interval.
    notes
        Anything a reader must know (inversions that could not run, and why).
    fit
        Goodness of fit of the best hypothesis (:mod:`diagnostics.goodness`); when it
        fails, no fault is named.
    healthy_end
        Single-fault hypotheses whose fit sits on the healthy end of its worn range, or
        whose interval reaches it (and whose component has no closed-form inversion),
        profiled from the rig document's value up (:mod:`diagnostics.healthy_end`): the
        component's value when it may be worn less than the worn range assumes, by
        hypothesis name (``at_bound``: at the document's value); only those whose profile
        passes the goodness-of-fit test.
    reading_sigma
        Per record, each reading's standard uncertainty as the likelihood of the most
        probable hypothesis weighs it [SI unit of the reading]: the measurement's own,
        the model's and the stated condition's at that hypothesis's estimate
        (:mod:`diagnostics.record_model`, :mod:`diagnostics.evidence_at_fit`; the
        condition's part moves every reading of a record at once, so the readings'
        errors are correlated).
    regime_notes
        End-stop states met by the maps (which hypothesis values hold the piston on its
        stop, predicted in that state, and whether the healthy rig's does) and the values
        masked for want of a prediction.
    """

    rig: str
    hypotheses: list[HypothesisFit]
    isolability: Isolability
    direct: dict[str, Estimate] = field(default_factory=dict)
    ratio: RatioIndex | None = None
    pump_slip: tuple[float, float, float] | None = None
    n_records: int = 1
    n_observations: int = 0
    notes: list[str] = field(default_factory=list)
    fit: GoodnessOfFit | None = None
    regime_notes: list[str] = field(default_factory=list)
    healthy_end: dict[str, ParameterEstimate] = field(default_factory=dict)
    reading_sigma: list[dict[str, float]] = field(default_factory=list)

    @property
    def top(self) -> HypothesisFit:
        """The most probable hypothesis, whether or not it explains the readings: read
        :attr:`explained` (or :attr:`answer`) before acting on its name (readings in bar
        typed as Pa gave ``top.name == "healthy"`` p 1.0 where the answer is "unexplained":
        a library user's pass)."""
        return self.hypotheses[0]

    @property
    def answer(self) -> str:
        """The name the diagnosis gives: the top hypothesis's where some hypothesis
        explains the readings, else ``"unexplained"`` (``to_dict()["top"]``)."""
        return self.top.name if self.explained else "unexplained"

    @property
    def explained(self) -> bool:
        """Whether some hypothesis of the library explains the readings (χ² test)."""
        return self.fit is None or self.fit.explained

    @property
    def confident(self) -> bool:
        """Whether the name is a confident answer: explained by a χ² test, no fault
        beyond the prior ranges explains the readings as well
        (:attr:`diagnostics.goodness.GoodnessOfFit.confident`), and some fault could have
        been seen (not :attr:`blind`)."""
        return (self.fit is None or self.fit.confident) and not self.blind

    @property
    def blind(self) -> bool:
        """Whether no fault hypothesis is observable with these readings (each one's most
        severe value moves them by less than one standard uncertainty): healthy is then the
        only name left, and it says that nothing was seen, not that the rig is healthy."""
        return not any(f.observable for f in self.hypotheses if f.hypothesis.components)

    @property
    def isolated(self) -> bool:
        """Whether the name's components can be acted on: a confident answer whose faulty
        components are in every hypothesis of the 95 % credible set (so they are implicated
        with at least 95 % probability: a worn spool's ``valve`` with ``valve+pump`` beside
        it); a healthy answer only when it holds 95 % alone.  ``confident`` does not say the
        name is certain: a worn spool read by the three pressures alone came out ``pump``
        p = 0.30, confident, six hypotheses in the ambiguity set (an engineer's pass)."""
        if not self.confident:
            return False
        named = set(self.top.hypothesis.components)
        by_name = {f.name: set(f.hypothesis.components) for f in self.hypotheses}
        cred = self.isolability.credible_set
        if not named:
            return cred == [self.top.name]
        return bool(cred) and all(named <= by_name[n] for n in cred)

    def to_dict(self) -> dict[str, Any]:
        """Plain Python form (SI units, stated per field): dicts, lists, strings and
        numbers, with ``nan`` where a value is not defined (``chi2_at_estimate`` of a
        hypothesis without a parameter); strict JSON needs those as null, as the service's
        answers write them (:func:`app.services.diagnosis_estimates.json_ready`)."""
        def fit(f: HypothesisFit) -> dict[str, Any]:
            return {
                "name": f.name, "components": list(f.hypothesis.components),
                "description": f.hypothesis.description,
                "probability": f.probability, "observable": f.observable,
                "chi2": f.chi2, "chi2_at_estimate": f.chi2_at_estimate,
                "log_evidence": f.log_evidence,
                "parameters": [plain(p) | {"multiple_of": MULTIPLE_OF.get(p.name, "")}
                               for p in f.parameters],
                "predicted": f.predicted,
            }
        iso = self.isolability
        return {
            "rig": self.rig,
            "top": self.answer,
            "best_fit": self.top.name,
            "hypotheses": [fit(f) for f in self.hypotheses],
            "isolability": {
                "ambiguity_set": iso.ambiguity_set, "credible_set": iso.credible_set,
                "not_observable": iso.not_observable,
                "parallel_signatures": [list(p) for p in iso.parallel],
                "separations": [plain(s) for s in iso.separations],
                "statements": iso.statements,
            },
            "direct_inversions": {k: plain(e, skip=("sensitivities", "contributions"))
                                  for k, e in self.direct.items()},
            "ratio_index": plain(self.ratio) if self.ratio is not None else None,
            "pump_slip_Cs": (None if self.pump_slip is None else
                             dict(zip(("value", "low", "high"), self.pump_slip, strict=True))),
            "n_records": self.n_records,
            "n_observations": self.n_observations,
            "observable_units": OBSERVABLE_UNITS,
            "notes": self.notes,
            "explained": self.explained,
            "confident": self.confident,
            "isolated": self.isolated,
            "goodness_of_fit": None if self.fit is None else plain(self.fit),
            "misfit": None if self.explained or self.fit is None else self.fit.statement,
            "regime_notes": self.regime_notes,
            "healthy_end": {k: plain(e) for k, e in self.healthy_end.items()},
            "reading_sigma": self.reading_sigma,
        }


#: the note of a diagnosis whose readings can see no fault (:attr:`Diagnosis.blind`): huge
#: stated uncertainties, or one weak reading, came back "healthy, p = 1.000, isolated"
#: (an edge pass)
BLIND_NOTE = ("no fault hypothesis is observable with these readings (the most severe wear "
              "of each moves them by less than one standard uncertainty): 'healthy' says that "
              "nothing was seen, not that the rig is healthy; readings with smaller "
              "uncertainties, or more of them, can see faults")

#: the field names of each dataclass :func:`plain` has met
_FIELDS: dict[type, tuple[str, ...]] = {}


def plain(obj: Any, skip: tuple[str, ...] = ()) -> Any:
    """``obj`` as :func:`dataclasses.asdict` gives it — dataclasses as dicts of their
    fields (``skip`` left out at the top), lists, tuples and dicts rebuilt, recursively —
    without copying the leaves (asdict deep-copies each: 0.17 → 0.10 ms for a diagnosis's
    :meth:`Diagnosis.to_dict`, measured; the leaves here are numbers and strings)."""
    kind = type(obj)
    names = _FIELDS.get(kind)
    if names is None:
        if kind is list or kind is tuple:
            return kind(plain(v) for v in obj)
        if kind is dict:
            return {k: plain(v) for k, v in obj.items()}
        if not (is_dataclass(obj) and not isinstance(obj, type)):
            return obj
        names = _FIELDS[kind] = tuple(f.name for f in fields(obj))
    return {n: plain(getattr(obj, n)) for n in names if n not in skip}
