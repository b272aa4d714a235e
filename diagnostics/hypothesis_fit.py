"""What fitting a fault hypothesis gives: its estimates, their severity, the fit.

:class:`~diagnostics.ranking.Ranker` fits each hypothesis of :mod:`diagnostics.hypotheses`
to the records and returns a :class:`HypothesisFit` for each: χ², evidence, probability
and one :class:`ParameterEstimate` per freed parameter, with its 95 % interval, its
leakage multiple or setting drift (:data:`MULTIPLE_OF`) and the severity label an
engineer reads (:func:`severity`).  These are the results the diagnosis, the evidence at
the fit, the goodness of fit and the isolability read, without the fitting itself
(:mod:`diagnostics.ranking`, which exports them too).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from diagnostics.hypotheses import FaultParameter, Hypothesis

__all__ = ["MULTIPLE_OF", "HypothesisFit", "ParameterEstimate", "severity"]


#: what :attr:`ParameterEstimate.multiple` is, per parameter, as the JSON says it beside it
#: (``multiple_of``): three meanings under one name read as "0.65 × nominal" for a relief
#: setting 65 % low (an engineer's pass)
MULTIPLE_OF: dict[str, str] = {
    "cc": "laminar leakage past the piston, (c/c0)^3 [-]",
    "cv": "laminar leakage through the spool, (c/c0)^3 [-]",
    "pump_leak": "the pump's internal leakage, the value itself (leak = value·Δp/Rlp) [-]",
    "seat_leak": "1 + the seat's leakage in units of the pump's nominal leakage [-]",
    "Pset": "drift of the setting, 1 − value/nominal (0.65: 65 % low) [-]",
}


def severity(param: FaultParameter, value: float, nominal: float) -> tuple[float, str]:
    """(leakage multiple or setting drift, label) of a fitted parameter.

    Clearances count by their laminar leakage (``(c/c0)³``), leakage factors by
    themselves; labels: < 1.33 ``none``, < 2.2 ``mild``, < 4.1 ``moderate``, else
    ``severe`` (1.1, 1.3 and 1.6 times the clearance).  A relief setting counts by its
    drift: < 5 % ``none``, < 10 % ``mild``, < 20 % ``moderate``, else ``severe``.
    """
    if param.name == "Pset":
        drift = 1.0 - value / nominal
        return drift, _label(drift, (0.05, 0.10, 0.20))
    if param.name in ("cc", "cv"):
        mult = (value / nominal) ** 3
    elif param.name == "seat_leak":
        mult = 1.0 + value
    else:
        mult = value
    return mult, _label(mult, (1.33, 2.2, 4.1))


def _label(x: float, edges: tuple[float, float, float]) -> str:
    """``none``, ``mild``, ``moderate`` or ``severe`` by the ``edges``; a value on an edge
    to round-off (1e-9 relative: a worn range starts on the ``mild`` edge, and a clearance
    there read 1.3299999999999983 and ``none`` where another read 1.3300000000000032 and
    ``mild``; a user pass) takes the label above it."""
    for edge, label in zip(edges, ("none", "mild", "moderate"), strict=True):
        if x < edge - 1e-9 * abs(edge):
            return label
    return "severe"


@dataclass
class ParameterEstimate:
    """A fitted fault parameter with its 95 % interval.

    Attributes
    ----------
    name, component, unit
        Which parameter (see :mod:`diagnostics.hypotheses`) and its unit.
    value, low, high
        Estimate and 95 % interval [unit].
    nominal
        Value on the healthy rig [unit].
    multiple
        Leakage multiple (clearances, leak factors) or relative drift (relief setting) [-].
    severity
        ``none``, ``mild``, ``moderate`` or ``severe``.
    at_bound
        The estimate sits on the healthy end of its (worn) range: no more wear than the
        hypothesis must assume.
    """

    name: str
    component: str
    unit: str
    value: float
    low: float
    high: float
    nominal: float
    multiple: float
    severity: str
    at_bound: bool


@dataclass
class HypothesisFit:
    """One hypothesis fitted to the records.

    Attributes
    ----------
    hypothesis
        The hypothesis.
    chi2
        χ² at the estimate, the readings weighed by the ranking's covariance (the stated
        condition through the healthy rig's sensitivity).
    chi2_at_estimate
        χ² at the estimate with the stated condition's sensitivity taken there
        (:mod:`diagnostics.evidence_at_fit`; NaN where not computed: healthy, or no
        covariance there).
    log_evidence
        ln Z (up to a constant shared by all hypotheses).
    parameters
        Fitted parameters.
    predicted
        Predicted observables at the estimate, one mapping per record [SI].
    observable
        False when the hypothesis cannot be seen with these sensors at these conditions.
    probability
        Posterior probability among the observable hypotheses.
    """

    hypothesis: Hypothesis
    chi2: float
    log_evidence: float
    parameters: list[ParameterEstimate]
    predicted: list[dict[str, float]]
    observable: bool = True
    probability: float = 0.0
    detectability: float = field(default=math.inf)
    chi2_at_estimate: float = field(default=math.nan)

    @property
    def name(self) -> str:
        """Hypothesis name."""
        return self.hypothesis.name
