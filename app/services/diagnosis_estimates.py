"""What the history keeps of a diagnosis: each suspect component's estimate with its
interval and probability (:func:`estimates_of`), and the result as JSON the store takes
(:func:`json_ready`).

Split from :mod:`app.services.diagnosis` (a code review: the module held diagnosing,
storing, the estimates and the answer at 578 lines); that module re-exports these names.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from app.services.history import ComponentEstimate
from diagnostics.diagnose import CLEARANCES, Diagnosis

__all__ = ["EstimateOut", "estimates_of", "json_ready"]


@dataclass(frozen=True, slots=True)
class EstimateOut:
    """One component's estimate: value and 95 % interval [unit], probability [1], and its
    source: ``"direct"`` (closed-form inversion), ``"hypothesis"`` (single-fault fit) or
    ``"profile"`` (that fit sat on the healthy end of its worn range: profiled from the
    rig document's value up, :mod:`diagnostics.healthy_end`)."""

    component: str
    quantity: str
    unit: str
    value: float
    low: float
    high: float
    probability: float
    source: str

    def history(self) -> ComponentEstimate:
        """The estimate as the history keeps it (one trend point)."""
        if self.quantity == "Cs":
            return ComponentEstimate(self.component, self.probability,
                                     slip_coefficient=self.value, low=self.low, high=self.high)
        return ComponentEstimate(self.component, self.probability, clearance_m=self.value,
                                 low=self.low, high=self.high)



def json_ready(value: Any) -> Any:
    """``value`` with every non-finite float as ``None`` and numpy scalars as Python ones.

    JSON has no NaN or infinity; a diagnosis uses them for "no value" (an unobservable
    hypothesis's evidence, an infinite duration).  The plain types are told by their exact
    type first (a diagnosis's ~1,500 values: 0.18 → 0.05 ms, measured), the rest as
    before.
    """
    kind = type(value)
    if kind is float:
        return value if math.isfinite(value) else None
    if kind is dict:
        return {k if type(k) is str else str(k): json_ready(v) for k, v in value.items()}
    if kind is list or kind is tuple:
        return [json_ready(v) for v in value]
    if value is None or kind is str or kind is int or kind is bool:
        return value
    if isinstance(value, Mapping):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    if isinstance(value, bool | str | int):
        return value
    if hasattr(value, "item"):  # numpy scalar
        return json_ready(value.item())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value


def estimates_of(diagnosis: Diagnosis) -> list[EstimateOut]:
    """Per-component estimates: what the history keeps for the trends.

    Cylinder and valve: the equivalent clearance [m] of the closed-form inversion of paper
    002 §2.7 when the record carries the flows it needs (it does not depend on which
    hypothesis wins), else the fitted clearance of the component's single-fault hypothesis
    when the readings cannot reject that hypothesis (its ambiguity set).  A joint visit
    (several records) keeps that fit, made from every record, where the readings do not
    reject it, before the closed form of its most precise record.  Pump: the laminar
    slip coefficient Cs [-] of paper 000 eq. 6 under the pump hypothesis, when that is not
    rejected.  A rejected hypothesis's fit explains the readings by the wrong component
    and estimates nothing, so it is left out.

    A fit on the healthy end of its worn range says only "no more worn than the range's
    start"; the component's value is then the profile from the rig document's value up
    (:attr:`~diagnostics.diagnose.Diagnosis.healthy_end`, source ``"profile"``), kept when
    the profile passes the goodness-of-fit test whether or not the worn range's fit did:
    a seal wearing from its document's value toward the worn range is stored where it is,
    neither at the range's start with an interval that excludes it nor left out.
    ``probability`` is the probability that the component is worn, alone or in a pair: the
    sum over the hypotheses that name it.  Until 2026-11-28 it was its single-fault
    hypothesis's alone, so a valve in a near-certain valve+pump pair read p = 1e-12 and
    the trends drew its estimate as "if the valve is the worn one" (a first-day user pass);
    rows stored before then keep that meaning.  When no hypothesis explains the readings
    it is 0, as the answer's own probability is: the hypotheses' probabilities are then
    relative among themselves only, and an unexplained record's estimate read "worn,
    p = 1.0" (an edge pass).
    """
    fits = {f.name: f for f in diagnosis.hypotheses}
    plausible = set(diagnosis.isolability.ambiguity_set)
    worn = {c: sum(f.probability for f in diagnosis.hypotheses
                   if c in f.name.split("+") and math.isfinite(f.probability))
            if diagnosis.explained else 0.0
            for c in (*CLEARANCES, "pump")}
    out: list[EstimateOut] = []
    for component, quantity in CLEARANCES.items():
        fit = fits.get(component)
        probability = min(worn[component], 1.0)
        direct = diagnosis.direct.get(quantity)
        # a joint visit: the closed form inverts one record, the fit all of them (a worn
        # spool's visit at three loads stored cv 56.4 [51.8, 61.0] µm from its first
        # record beside a fit of 55.2 [54.4, 56.0]; an engineer's pass)
        joint = (diagnosis.n_records > 1 and fit is not None and fit.observable
                 and component in plausible and component not in diagnosis.healthy_end)
        if direct is not None and not joint:
            out.append(EstimateOut(component, quantity, direct.unit, direct.value, direct.low,
                                   direct.high, probability, "direct"))
        elif component in diagnosis.healthy_end:
            p = diagnosis.healthy_end[component]
            out.append(EstimateOut(component, quantity, p.unit, p.value, p.low, p.high,
                                   probability, "profile"))
        elif fit is not None and fit.observable and component in plausible:
            (p,) = fit.parameters
            out.append(EstimateOut(component, quantity, p.unit, p.value, p.low, p.high,
                                   probability, "hypothesis"))
    pump = fits.get("pump")
    if pump is not None and diagnosis.pump_slip is not None and (
            "pump" in plausible or "pump" in diagnosis.healthy_end):
        value, low, high = diagnosis.pump_slip
        out.append(EstimateOut("pump", "Cs", "1", value, min(low, high), max(low, high),
                               min(worn["pump"], 1.0),
                               "profile" if "pump" in diagnosis.healthy_end else "hypothesis"))
    return [e for e in out if all(math.isfinite(x) for x in (e.value, e.low, e.high))]
