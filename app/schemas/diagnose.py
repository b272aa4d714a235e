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
from typing import Annotated, Any, ClassVar

from pydantic import (
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
from app.schemas.diagnosis_public import (
    DiagnoseResponse,
    DiagnosisPublic,
    DisagreementPublic,
    EstimatePublic,
    GoodnessOfFitPublic,
)
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


#: one record of a visit at two loads read by the same instruments (a spool worn to 60 µm)
_VISIT_RECORD: dict[str, Any] = {
    "rig_id": 1,
    "measured_at": "2026-11-22T08:30:00Z",
    "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
    "pump_pressure": 14.5e5, "p1": 11.9e5, "p2": 1.2e5, "flow_B": 4.64e-4, "flow_C": 4.17e-4,
    "speed_work": 0.188, "speed_return": 0.218,
    "calibration_share": 1.0,
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
    calibration_share: float | None = Field(
        default=None, ge=0.0, le=1.0,
        description="Share of each stated variance (readings, load, oil temperature, pump "
        "speed) that is the instrument's calibration error, the same in every record of a "
        "`joint` diagnosis that the instrument reads: the visit's intervals then count it "
        "(1: the stated uncertainties are calibration errors, as an instrument class "
        "mostly is); null or 0: errors independent between records [-]",
        examples=[None],
    )

    model_config = ConfigDict(json_schema_extra={"examples": [_EXAMPLE_RECORD]})


class DiagnoseRequest(RequestModel):
    """One record (``record``) or a batch (``records``) to diagnose."""

    model_config = ConfigDict(json_schema_extra={"examples": [
        {"record": _EXAMPLE_RECORD},
        {"record": _EXAMPLE_RECORD, "store": False, "compact": True},
        {"records": [_VISIT_RECORD, _VISIT_RECORD | {
            "measured_at": "2026-11-22T08:32:00Z",
            "condition": {"oil_temperature": 40.0, "load_force": 4200.0},
            "pump_pressure": 24.3e5, "p1": 21.7e5, "p2": 1.18e5, "flow_B": 4.63e-4,
            "flow_C": 3.79e-4, "speed_work": 0.161, "speed_return": 0.218}],
         "joint": True, "store": False},
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
