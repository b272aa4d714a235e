"""The result of the goodness-of-fit test (:mod:`diagnostics.goodness`): the χ² test of the
best-fitting observable hypothesis, its range tests, and the readings that disagree."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from diagnostics.range_test_result import RangeTest

__all__ = ["NOISE_FACTOR", "Disagreement", "GoodnessOfFit", "UnitMistake",
           "uncertainty_factor"]

#: the largest uncertainty factor at which a statement offers noisier instruments than
#: stated as a cause [-]: in ``make accuracy`` the answers not explained when every
#: instrument scatters within 2 × its class have factors ≤ 2 in 97-100 %
#: (:mod:`benchmarks.accuracy_noise`); a factor beyond 3 is no instrument's noise
NOISE_FACTOR = 3.0


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


@dataclass(frozen=True)
class UnitMistake:
    """A mistake in the readings' units that, undone, lets the rig model explain them
    (:mod:`diagnostics.unit_mistakes`).

    Attributes
    ----------
    mistake
        ``"absolute_pressure"`` or ``"fahrenheit"``.
    hypothesis, probability
        The most probable hypothesis on the corrected readings and its probability [-].
    chi2, dof, limit
        The goodness-of-fit test's χ² on the corrected readings, its degrees of freedom and
        limit [-].
    statement
        One sentence for a reader.
    """

    mistake: str
    hypothesis: str
    probability: float
    chi2: float
    dof: int
    limit: float
    statement: str


@dataclass
class GoodnessOfFit:
    """χ² test of the best-fitting observable hypothesis.

    Attributes
    ----------
    hypothesis
        The hypothesis reported: the first that passes (in the order of
        :mod:`diagnostics.goodness`' docstring), else the observable one with the highest p-value.
    chi2
        Its χ² at the estimate [-].
    dof
        Degrees of freedom ν = n − k, 0 when k ≥ n (no χ² test) [-].
    level
        Test level α [-].
    limit
        χ²_{1-α}(ν) [-]; infinite when ν = 0.
    p_value
        P(χ²_ν ≥ χ²) [-]; 1 when ν = 0.
    explained
        Whether some observable hypothesis passes the test.
    testable
        Whether the conclusion rests on a χ² test: false when the readings are explained
        only by hypotheses with as many parameters as readings (a misfit cannot be
        detected with these readings; the statement says so).
    range_tests
        The range tests run (:mod:`diagnostics.range_test`), in the order tried.
    beyond_range
        Single-fault hypotheses pinned on the severe bound of their prior whose range
        test rejects the range and whose fit beyond it passes the χ² test: explanations
        outside the library's ranges that the readings allow as well (a relief setting
        below 0.3 × nominal on a held piston reads as a worn spool without flow meters).
        When there is one, the name is not a confident answer: the statement says so.
    incipient
        The range test of the explaining hypothesis when the readings place one of its
        parameters between the rig document's value and the start of its worn range
        (:func:`diagnostics.range_test._incipient`): wear too small for the worn range,
        or a rig document off by that much.  ``chi2`` is then the χ² at those values;
        the name is not a confident answer and the statement says why.
    disagreements
        Readings of the tested fit beyond 3 σ, worst first (the worst three when none is).
    statement
        One sentence for a reader.
    uncertainty_factor
        The common factor on every uncertainty (readings, stated conditions, model) at
        which the reported fit's χ² reaches the test's limit, √(χ²/limit) with the limit
        of ν, or of the number of readings where ν = 0 [-]; above 1, how much more than
        stated the readings would have to scatter for the fit to pass; None where χ² is
        not finite.
    unit_mistakes
        Mistakes in the readings' units (absolute pressures, a temperature in °F) that,
        undone, let a hypothesis explain readings that are not explained
        (:mod:`diagnostics.unit_mistakes`); empty when explained or when none does.
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
    testable: bool = True
    range_tests: list[RangeTest] = field(default_factory=list)
    beyond_range: list[RangeTest] = field(default_factory=list)
    incipient: RangeTest | None = None
    uncertainty_factor: float | None = None
    unit_mistakes: list[UnitMistake] = field(default_factory=list)

    @property
    def confident(self) -> bool:
        """Explained, by a χ² test, with no explanation beyond the prior ranges as good
        and no value of the explaining fit below its worn range."""
        return (self.explained and self.testable and not self.beyond_range
                and self.incipient is None)


def uncertainty_factor(chi2: float, limit: float) -> float | None:
    """The common factor s on every uncertainty of the readings (instruments, stated
    conditions, model) at which a fit's χ² reaches the test's ``limit`` [-]: √(χ²/limit)
    (scaling the whole covariance by s² divides χ² by s² and leaves the estimate where it
    is); None where χ² is not finite.  Above 1, how much more than stated the readings
    would have to scatter for the fit to explain them; below 1, the fit's margin."""
    if not (math.isfinite(chi2) and math.isfinite(limit)) or limit <= 0.0:
        return None
    return math.sqrt(max(chi2, 0.0) / limit)
