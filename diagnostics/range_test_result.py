"""The result of a range test (:mod:`diagnostics.range_test`): a likelihood-ratio test of
a hypothesis's prior range, with the clause a reader gets."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from diagnostics.hypotheses import PARAMETERS
from sim.units import quantity_text

__all__ = ["RangeTest"]


@dataclass
class RangeTest:
    """Likelihood-ratio test of a hypothesis's prior range (module docstring).

    Attributes
    ----------
    hypothesis
        Hypothesis tested.
    parameters
        Its parameters pinned at a bound.
    sides
        For each: ``"severe"`` (the fault would be larger than the range allows),
        ``"healthy"`` (the component would be better than the rig document says),
        ``"incipient"`` (between the rig document's value and the start of the worn
        range: wear too small for the library's worn range, or a document off by that
        much) or ``"document"`` (at the document's value: not worn;
        :func:`diagnostics.range_test._incipient`).
    chi2_bounded, chi2_extended
        χ² at the bounded estimate and at the best fit with the ranges extended [-].
    statistic
        Λ = χ²_b − χ²_e [-].
    dof
        Number of pinned parameters m [-].
    limit
        χ²_{1-α}(m) [-].
    rejected
        Λ > limit: the readings ask for a value beyond the range (for ``"incipient"``
        parameters the range extended to the rig document's value holds, so the test
        does not reject).
    extended
        The best values beyond the range, by parameter [unit of the parameter]; with
        ``"incipient"`` parameters, the best values with the range extended to the rig
        document's value.
    chi2_document
        Best χ² with the healthy-side ranges extended only to the rig document's value
        (:func:`diagnostics.range_test._incipient`; NaN where that test was not needed)
        [-]: the hypothesis's χ² with its ``"incipient"`` values.
    """

    hypothesis: str
    parameters: list[str]
    sides: list[str]
    chi2_bounded: float
    chi2_extended: float
    statistic: float
    dof: int
    limit: float
    rejected: bool
    extended: dict[str, float] = field(default_factory=dict)
    chi2_document: float = math.nan

    def describe(self) -> str:
        """One clause for a reader."""
        what = ", ".join(
            f"{p} {_SIDE_WORDS[s]} (best {_shown(p, self.extended.get(p, math.nan))})"
            for p, s in zip(self.parameters, self.sides, strict=True))
        return (f"{self.hypothesis} sits on the bound of its prior and its likelihood still "
                f"rises past it ({what}: χ² {self.chi2_bounded:.3g} → "
                f"{self.chi2_extended:.3g}, Λ = {self.statistic:.3g} > {self.limit:.3g})")

    @property
    def incipient(self) -> dict[str, float]:
        """The parameters the readings place between the rig document's value and the
        start of the worn range (incipient wear), with those values [unit]; empty when
        the test rejects the range."""
        if self.rejected:
            return {}
        return {p: self.extended[p] for p, s in zip(self.parameters, self.sides, strict=True)
                if s == "incipient"}


def _shown(name: str, value: float) -> str:
    """A fault parameter's value with its unit as an engineer reads it: "best 1.112e+06"
    was a relief setting of 11.1 bar (a plant operator's pass)."""
    unit = PARAMETERS[name].unit if name in PARAMETERS else ""
    if unit == "Pa" and math.isfinite(value):
        return f"{value / 1e5:.4g} bar"
    return quantity_text(value, unit)


#: how :meth:`RangeTest.describe` words each side
_SIDE_WORDS = {"severe": "beyond its worn range",
               "healthy": "better than the rig document",
               "incipient": "below its worn range, worse than the rig document",
               "document": "at the rig document's value, not worn"}
