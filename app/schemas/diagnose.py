"""Measurement records and their diagnosis.

A record names its rig (and optionally the version of its document) and carries any subset
of the quantities of :class:`diagnostics.measurement.MeasurementRecord`, under the same
names.  Each reading is a bare number — a reading of the field's default instrument class
(:data:`diagnostics.quantity.DEFAULT_INSTRUMENTS`) — or an object with its standard
uncertainty ``u`` or its instrument bound ``bound`` (read as rectangular, u = bound/√3).
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (
    AwareDatetime,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    GetJsonSchemaHandler,
    model_validator,
)
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema, PydanticCustomError

from app.limits import BATCH_RECORDS_CEILING
from app.schemas.common import MAX_ID, FiniteFloat, RequestModel
from app.schemas.times import MeasurementTime
from sim.errors import InputError

__all__ = [
    "MEASURED_FIELDS",
    "ConditionIn",
    "DiagnoseRequest",
    "DiagnoseResponse",
    "DiagnosisPublic",
    "DisagreementPublic",
    "EstimatePublic",
    "GoodnessOfFitPublic",
    "MeasurementIn",
    "ReadingIn",
]

#: Measured quantities of a record: name → (unit, meaning); names as in diagnostics.
MEASURED_FIELDS: dict[str, tuple[str, str]] = {
    "pump_pressure": ("Pa", "Pump outlet pressure, gauge"),
    "p1": ("Pa", "Chamber 1 pressure in the working phase, gauge"),
    "p2": ("Pa", "Chamber 2 pressure in the working phase, gauge"),
    "flow_B": ("m³/s", "Flow into the directional valve's P port (meter B)"),
    "flow_C": ("m³/s", "Flow out of the cylinder in the working phase (meter C)"),
    "pump_flow": ("m³/s", "Flow at the pump outlet"),
    "speed_work": ("m/s", "Average piston speed in the working phase"),
    "speed_return": ("m/s", "Average piston speed in the return phase"),
    "duration_work": ("s", "Duration of the working stroke"),
    "duration_return": ("s", "Duration of the return stroke"),
    "stroke": ("m", "Distance travelled in each phase"),
    "velocity_ratio": ("1", "Working over return average speed"),
}

_EXAMPLE_RECORD: dict[str, Any] = {
    "rig_id": 1,
    "measured_at": "2026-11-22T08:30:00Z",
    "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
    "pump_pressure": 14.6e5,
    "p1": 11.9e5,
    "p2": 1.2e5,
    "flow_B": {"value": 4.44e-4, "u": 2.6e-6},
    "flow_C": 3.97e-4,
    "speed_work": 0.180,
    "speed_return": 0.215,
}


class ReadingIn(RequestModel):
    """A reading with its uncertainty; give ``u`` or ``bound``, or neither for the default.

    A bare number in place of this object is a reading of the field's default instrument
    class (:data:`diagnostics.quantity.DEFAULT_INSTRUMENTS`).
    """

    value: FiniteFloat = Field(
        description="Reading, in the SI unit of the field it stands in [unit of the field]",
        examples=[4.44e-4],
    )
    u: FiniteFloat | None = Field(
        default=None, ge=0,
        description="Standard uncertainty (one standard deviation) [unit of the field]",
        examples=[2.6e-6],
    )
    bound: FiniteFloat | None = Field(
        default=None, ge=0,
        description="Instrument bound ±a, read as rectangular with u = a/√3 "
        "[unit of the field]",
        examples=[4.4e-6],
    )

    @model_validator(mode="after")
    def _one_uncertainty(self) -> ReadingIn:
        if self.u is not None and self.bound is not None:
            raise ValueError("give u or bound, not both")
        return self


def _number_to_reading(value: Any) -> Any:
    """A bare number is a reading of the field's default instrument class; text is not a
    number (a pasted ``p1: NaN`` read "should be a valid dictionary or instance of
    ReadingIn")."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return {"value": value}
    if isinstance(value, str):
        raise PydanticCustomError(
            "reading_text", "a reading is a number or an object (value, u), not the text {text} "
            "(leave a reading that was not taken out)", {"text": repr(value[:40])})
    return value


class _NumberOrReading:
    """The schema of a reading as the service takes it: a bare number or a
    :class:`ReadingIn` object.  The document offered the object only, so 23 of its own
    examples (bare numbers, as the README and ``GET /series/{id}/record`` write them) failed
    their schema and a generated client refused them (an API client's pass)."""

    def __get_pydantic_json_schema__(self, core: CoreSchema,
                                     handler: GetJsonSchemaHandler) -> JsonSchemaValue:
        return {"anyOf": [{"type": "number"}, handler(core)]}


#: A reading: ``12.5`` is short for ``{"value": 12.5}`` (default instrument class).
Reading = Annotated[ReadingIn, BeforeValidator(_number_to_reading), _NumberOrReading()]


def _reading(unit: str, meaning: str, example: float, *, required: bool = False) -> Any:
    return Field(
        ... if required else None,
        description=f"{meaning}: a number (default instrument class) or {{value, u | bound}} "
        f"[{unit}]",
        examples=[example],
    )


class ConditionIn(RequestModel):
    """Operating condition of a record: the load force, or the back-pressure.

    ``load_force`` is a force on the piston (paper 002's model: its 10/20/30 bar
    "back-pressure" loads are equivalent loads F = p·A2, 2.1/4.2/6.3 kN, and a throttle
    table's ``back_pressure_pa`` means that).  ``back_pressure`` stated alone is a pressure
    the load valve holds in the cylinder's outlet line: chamber 2 and P2 see it and the
    piston's pressure difference is friction only, another operating point (a record at a
    throttle table's condition states ``load_force`` = p·A2).  Both stated must agree as
    F = p·A2 and are read as the force; a force and a separate back-pressure valve acting
    together cannot be stated."""

    synonyms: ClassVar[Mapping[str, str]] = {"load": "load_force"}

    oil_temperature: Reading = _reading("°C", "Oil temperature", 40.0, required=True)
    load_force: Reading | None = _reading("N", "Load on the piston, working phase", 2100.0)
    back_pressure: Reading | None = _reading(
        "Pa", "Back-pressure the load valve holds in the outlet line (alone: chamber 2 sees "
        "it; with load_force, the same load as F = p·A2)", 1.0e6)
    pump_speed: Reading | None = _reading("rad/s", "Pump shaft speed", 150.0)


_rig_id = partial(Field, ge=1, le=MAX_ID, description="Rig identifier [-]", examples=[1])
_rig_version = partial(
    Field, ge=1, le=MAX_ID,
    description="Version of the rig document to use; the latest when null [-]",
    examples=[None],
)


class MeasurementIn(RequestModel):
    """One visit's measurements on one rig (any subset of the quantities)."""

    rig_id: int = _rig_id()
    rig_version: int | None = _rig_version(default=None)
    measured_at: MeasurementTime | None = Field(
        default=None,
        description="When the readings were taken, ISO 8601 with zone, from 1970 to a day "
        "ahead of the service's clock; the time of the request when null [UTC]",
        examples=["2026-11-22T08:30:00Z"],
    )
    series_id: int | None = Field(
        default=None, ge=1, le=MAX_ID,
        description="Stored series of the record's rig the readings were read from "
        "(GET /series/{id}/record puts it here); kept with the record in the history [-]",
        examples=[None],
    )
    condition: ConditionIn = Field(
        description="Operating condition [-]",
        examples=[{"oil_temperature": 40.0, "load_force": 2100.0}],
    )
    pump_pressure: Reading | None = _reading("Pa", MEASURED_FIELDS["pump_pressure"][1], 14.6e5)
    p1: Reading | None = _reading("Pa", MEASURED_FIELDS["p1"][1], 11.9e5)
    p2: Reading | None = _reading("Pa", MEASURED_FIELDS["p2"][1], 1.2e5)
    flow_B: Reading | None = _reading("m³/s", MEASURED_FIELDS["flow_B"][1], 4.44e-4)
    flow_C: Reading | None = _reading("m³/s", MEASURED_FIELDS["flow_C"][1], 3.97e-4)
    pump_flow: Reading | None = _reading("m³/s", MEASURED_FIELDS["pump_flow"][1], 4.5e-4)
    speed_work: Reading | None = _reading("m/s", MEASURED_FIELDS["speed_work"][1], 0.180)
    speed_return: Reading | None = _reading("m/s", MEASURED_FIELDS["speed_return"][1], 0.215)
    duration_work: Reading | None = _reading("s", MEASURED_FIELDS["duration_work"][1], 2.78)
    duration_return: Reading | None = _reading("s", MEASURED_FIELDS["duration_return"][1],
                                               2.33)
    stroke: Reading | None = _reading("m", MEASURED_FIELDS["stroke"][1], 0.5)
    velocity_ratio: Reading | None = _reading("1", MEASURED_FIELDS["velocity_ratio"][1], 0.84)

    model_config = ConfigDict(json_schema_extra={"examples": [_EXAMPLE_RECORD]})


class DiagnoseRequest(RequestModel):
    """One record (``record``) or a batch (``records``) to diagnose."""

    model_config = ConfigDict(json_schema_extra={"examples": [
        {"record": _EXAMPLE_RECORD},
        {"record": _EXAMPLE_RECORD, "store": False, "compact": True},
    ]})

    record: MeasurementIn | None = Field(
        default=None, description="A single record; give this or `records` [-]",
        examples=[_EXAMPLE_RECORD],
    )
    records: list[MeasurementIn] | None = Field(
        default=None, min_length=1, max_length=BATCH_RECORDS_CEILING,
        description="Several records; each is diagnosed on its own unless `joint`; at most "
        "HYDRODIAG_MAX_BATCH_RECORDS (default 100) [-]",
        examples=[[_EXAMPLE_RECORD]],
    )
    joint: bool = Field(
        default=False,
        description="Diagnose all `records` together (one rig and version, e.g. one visit at "
        "several loads): one result for the batch [-]",
        examples=[False],
    )
    store: bool = Field(
        default=True,
        description="Store the records and results in the history (needs the API key) [-]",
        examples=[True],
    )
    compact: bool = Field(
        default=False,
        description="Answer with each diagnosis's summary: `result` without every "
        "hypothesis's predicted readings (about a fifth smaller: 14.3 → 11.6 kB for the "
        "README's record; the stored result keeps them) "
        "[-]",
        examples=[False],
    )

    def items(self) -> list[tuple[str, MeasurementIn]]:
        """The records with their paths in the request (``record``, ``records[2]``).

        Raises
        ------
        InputError
            Both or neither of ``record`` and ``records`` given, or ``joint`` with one
            record.
        """
        if (self.record is None) == (self.records is None):
            raise InputError("give either `record` or `records`", field="records")
        if self.record is not None:
            if self.joint:
                raise InputError("`joint` needs `records`", field="joint")
            return [("record", self.record)]
        return [(f"records[{i}]", r) for i, r in enumerate(self.records or [])]


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
    rig_id: int = _rig_id()
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
                   "statement": "the readings are consistent with valve"}])
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
