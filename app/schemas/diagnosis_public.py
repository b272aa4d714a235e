"""What ``POST /diagnose`` answers: each diagnosis with its estimates, its goodness of fit
and the readings that disagree (the request is :mod:`app.schemas.diagnose`')."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import AwareDatetime, BaseModel, Field

from app.schemas.common import MAX_ID

__all__ = ["DiagnoseResponse", "DiagnosisPublic", "DisagreementPublic", "EstimatePublic",
           "GoodnessOfFitPublic", "RangeTestPublic", "UnitMistakePublic"]


class EstimatePublic(BaseModel):
    """What a diagnosis estimated for one suspect component."""

    component: str = Field(description="Component [-]", examples=["valve"])
    quantity: str = Field(
        description="'cc' or 'cv' (equivalent clearance), 'Cs' (pump slip coefficient) [-]",
        examples=["cv"],
    )
    unit: str = Field(description="Unit of value, low and high [-]", examples=["m"])
    value: float = Field(description="Estimate [unit]", examples=[5.9e-5])
    low: float = Field(description="Lower end of the 95 % interval [unit]", examples=[5.6e-5])
    high: float = Field(description="Upper end of the 95 % interval [unit]", examples=[6.2e-5])
    probability: float = Field(
        ge=0, le=1, description="Probability that this component is worn, alone or in a "
        "pair: the sum over the hypotheses that name it; 0 when the readings are unexplained, "
        "as the answer's probability (diagnoses stored before 2026-11-28: its single-fault "
        "hypothesis's alone; until 2026-11-30 an unexplained one's sum as well) [1]",
        examples=[0.75],
    )
    source: Literal["direct", "hypothesis", "profile"] = Field(
        description="'direct': closed-form inversion of the flows (paper 002 §2.7); "
        "'hypothesis': fit of the component's single-fault hypothesis; 'profile': that fit "
        "sat on the healthy end of its worn range, so the value is profiled from the rig "
        "document's value up (a component worn less than the worn range assumes) [-]",
        examples=["direct"],
    )


class DisagreementPublic(BaseModel):
    """One reading against the best fit of the goodness-of-fit test."""

    record: int = Field(ge=0, description="Index of the record in the diagnosis [-]",
                        examples=[0])
    reading: str = Field(description="Reading (a record field name) [-]",
                         examples=["pump_pressure"])
    measured: float = Field(description="Reading [SI unit of the reading]", examples=[2.6e6])
    predicted: float | None = Field(
        description="Best fit's prediction; null where the model has none (no operating "
        "point, or the velocity ratio of a return stroke held on its stop) [SI unit of the "
        "reading]", examples=[3.4e6])
    sigma: float = Field(description="Standard uncertainty used in the fit [SI unit of the "
                         "reading]", examples=[8.6e3])
    deviation: float | None = Field(
        description="(measured − predicted)/σ; null where there is no prediction [σ]",
        examples=[-97.0])


class RangeTestPublic(BaseModel):
    """Likelihood-ratio test of a hypothesis's prior range: a fit pinned on a bound whose
    likelihood still rises past it (`diagnostics.range_test`)."""

    hypothesis: str = Field(description="Hypothesis tested [-]", examples=["pump"])
    parameters: list[str] = Field(description="Its parameters pinned on a bound [-]",
                                  examples=[["pump_leak"]])
    sides: list[str] = Field(
        description="Per parameter: 'severe' (a fault larger than the prior allows), "
        "'healthy' (a component better than the rig document says), 'incipient' (between "
        "the rig document's value and the start of the worn range: wear too small for the "
        "worn range, or a document off by that much) or 'document' (at the document's "
        "value: the component is not worn) [-]",
        examples=[["severe"]])
    chi2_bounded: float | None = Field(description="χ² at the bounded estimate [-]",
                                       examples=[320.8])
    chi2_extended: float | None = Field(
        description="Best χ² with the pinned ranges extended [-]", examples=[2.8])
    statistic: float | None = Field(description="Λ = χ²_bounded − χ²_extended [-]",
                                    examples=[318.0])
    dof: int = Field(ge=1, description="Number of pinned parameters [-]", examples=[1])
    limit: float = Field(description="χ² limit of Λ at the test level [-]", examples=[6.63])
    rejected: bool = Field(description="Whether the readings ask for a value beyond the "
                           "range [-]", examples=[True])
    extended: dict[str, float | None] = Field(
        description="Best values beyond the range, by parameter [unit of the parameter, "
        "see the hypothesis's parameters]", examples=[{"pump_leak": 30.1}])
    chi2_document: float | None = Field(
        default=None, description="Best χ² with the healthy-side ranges extended only to "
        "the rig document's value; null where that test was not needed [-]",
        examples=[None])


class UnitMistakePublic(BaseModel):
    """A mistake in the readings' units that, undone, lets the rig model explain them."""

    mistake: str = Field(description="'absolute_pressure' (every pressure one atmosphere, "
                         "101 325 Pa, high: absolute where gauge is asked) or 'fahrenheit' "
                         "(the oil temperature in °F where °C is asked) [-]",
                         examples=["absolute_pressure"])
    hypothesis: str = Field(description="Most probable hypothesis on the corrected readings "
                            "[-]", examples=["valve"])
    probability: float = Field(ge=0, le=1, description="Its probability [1]",
                               examples=[0.81])
    chi2: float = Field(description="The goodness-of-fit test's χ² on the corrected readings "
                        "[-]", examples=[2.8])
    dof: int = Field(ge=0, description="Degrees of freedom of that test [-]", examples=[6])
    limit: float = Field(description="χ² limit at the test level [-]", examples=[16.8])
    statement: str = Field(description="The mistake and what to send instead [-]",
                           examples=["the pressures look absolute where gauge pressures are "
                                     "asked: each 101325 Pa lower, the readings are explained "
                                     "(χ² = 2.8 on 6 degrees of freedom, limit 16.8), most "
                                     "probably valve (p = 0.81): send gauge pressures and "
                                     "diagnose again"])


class GoodnessOfFitPublic(BaseModel):
    """χ² goodness-of-fit test of the best-fitting hypothesis."""

    hypothesis: str = Field(description="Hypothesis tested (best p-value) [-]",
                            examples=["valve"])
    chi2: float | None = Field(description="χ² at its estimate; null if infinite [-]",
                               examples=[4.1])
    dof: int = Field(ge=0, description="Degrees of freedom ν = n − k; 0 when the hypothesis "
                     "has as many parameters as readings (no χ² test) [-]", examples=[6])
    level: float = Field(gt=0, lt=1, description="Test level α [1]", examples=[0.01])
    limit: float | None = Field(description="χ² limit at the test level; null when ν = 0 [-]",
                                examples=[16.8])
    p_value: float = Field(ge=0, le=1, description="P(χ²_ν ≥ χ²); 1 when ν = 0 [1]",
                           examples=[0.66])
    explained: bool = Field(description="Whether a hypothesis of the library passes [-]",
                            examples=[True])
    disagreements: list[DisagreementPublic] = Field(
        description="Readings beyond 3 σ of the tested fit, worst first (the worst three "
        "when none is) [-]", examples=[[]])
    statement: str = Field(description="The test's result in one statement [-]",
                           examples=["the readings are consistent with valve"])
    testable: bool = Field(
        default=True, description="Whether the conclusion rests on a χ² test; false when "
        "only hypotheses with as many parameters as readings explain them (a misfit cannot "
        "be detected with these readings) [-]", examples=[True])
    range_tests: list[RangeTestPublic] = Field(
        default_factory=list, description="Range tests run (fits pinned on a prior bound) "
        "[-]", examples=[[]])
    beyond_range: list[RangeTestPublic] = Field(
        default_factory=list, description="Single faults beyond their prior range that "
        "explain the readings as well; when any, the name is not a confident answer [-]",
        examples=[[]])
    incipient: RangeTestPublic | None = Field(
        default=None, description="Range test of the explaining hypothesis when the "
        "readings place a parameter between the rig document's value and the start of its "
        "worn range (incipient wear, or a document off by that much); χ² is then taken "
        "there, and the name is not a confident answer [-]", examples=[None])
    uncertainty_factor: float | None = Field(
        default=None, ge=0, description="Common factor on every uncertainty (readings, "
        "stated load and temperature, model) at which the tested fit's χ² reaches `limit` "
        "(of the number of readings where ν = 0): √(χ²/limit). Above 1, how much more than "
        "stated the instruments would have to scatter for the fit to explain the readings "
        "(a misfit at 1.2 may be noise; at 10 it is not); null where χ² is infinite, and in "
        "diagnoses stored before it was reported [-]", examples=[0.49])
    unit_mistakes: list[UnitMistakePublic] | None = Field(
        default=None, description="When not explained: mistakes in the readings' units that, "
        "undone, let a hypothesis explain them (tried: absolute pressures, a temperature in "
        "°F); the answer stays not explained. Empty when explained or when none does; null "
        "in diagnoses stored before it was reported [-]", examples=[[]])


class DiagnosisPublic(BaseModel):
    """The diagnosis of one record, or of several records jointly."""

    id: int | None = Field(description="Stored diagnosis id; null when not stored [-]",
                           examples=[12])
    measurement_ids: list[int] = Field(
        description="Stored measurement ids of the records, in request order; empty when "
        "not stored [-]", examples=[[31]],
    )
    records: list[str] = Field(description="Paths of the records in the request [-]",
                               examples=[["records[0]"]])
    rig_id: int = Field(ge=1, le=MAX_ID, description="Rig identifier [-]", examples=[1])
    rig_version: int = Field(ge=1, description="Version of the rig document used [-]",
                             examples=[1])
    measured_at: AwareDatetime = Field(
        description="Time of the (latest) record [UTC]", examples=["2026-11-22T08:30:00Z"])
    top: str = Field(description="Most probable hypothesis; 'unexplained' when no hypothesis "
                     "passes the goodness-of-fit test (see `misfit`) [-]", examples=["valve"])
    component: str = Field(
        description="Component(s) the top hypothesis blames, '+'-joined; 'healthy'; "
        "'unexplained' when nothing fits [-]",
        examples=["valve"],
    )
    probability: float = Field(ge=0, le=1, description="Probability of the top hypothesis; 0 "
                               "when unexplained [1]", examples=[0.75])
    explained: bool = Field(
        default=True, description="Whether a hypothesis of the rig's fault library explains "
        "the readings (χ² test at `goodness_of_fit.level`) [-]", examples=[True])
    goodness_of_fit: GoodnessOfFitPublic | None = Field(
        default=None, description="χ² goodness-of-fit test of the best hypothesis [-]",
        examples=[{"hypothesis": "valve", "chi2": 4.1, "dof": 6, "level": 0.01, "limit": 16.8,
                   "p_value": 0.66, "explained": True, "disagreements": [],
                   "statement": "the readings are consistent with valve",
                   "uncertainty_factor": 0.49, "unit_mistakes": []}])
    misfit: str | None = Field(
        default=None, description="When unexplained: which readings disagree by how many σ, "
        "and where to go next (discrepancy workflow, commissioning); null otherwise [-]",
        examples=[None])
    regime_notes: list[str] = Field(
        default_factory=list, description="End-stop states met (the piston held on its stop over "
        "a range of a hypothesis's values: predicted, speed 0) and values without a prediction "
        "(no operating point: masked) [-]", examples=[[]])
    estimates: list[EstimatePublic] = Field(
        description="Per-component estimates kept for the trends: closed-form where the "
        "flows allow, else the fit of a single-fault hypothesis the readings do not reject [-]",
        examples=[[]],
    )
    result: dict[str, Any] = Field(
        description="The full diagnosis: every hypothesis with its fitted parameters and "
        "predictions (left out of each hypothesis with `compact`), isolability, direct "
        "inversions; SI units stated per field [-]",
        examples=[{"top": "valve", "hypotheses": []}],
    )


class DiagnoseResponse(BaseModel):
    """Diagnoses of a request: one per record, or one for a joint batch."""

    mode: Literal["single", "each", "joint"] = Field(
        description="How the records were diagnosed [-]", examples=["single"])
    stored: bool = Field(description="Whether records and results were stored [-]",
                         examples=[True])
    compact: bool = Field(
        default=False, description="Whether each `result` leaves out the hypotheses' "
        "predicted readings (request option `compact`) [-]", examples=[False])
    notes: list[str] = Field(
        default_factory=list, description="What the service filled in: stored records "
        "without `measured_at` are kept at the request's time [-]", examples=[[]])
    diagnoses: list[DiagnosisPublic] = Field(description="The diagnoses, in request order [-]",
                                             examples=[[]])
