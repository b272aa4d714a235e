"""Measured time series of a rig: the upload form and what is read back (issue 12)."""

from __future__ import annotations

import re
from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, Field
from pydantic_core import PydanticCustomError

from app.schemas.common import MAX_ID, FiniteFloat, Page, PublicModel, UploadForm
from app.schemas.times import MeasurementTime, Timestamp
from diagnostics.timeseries import MAX_SAMPLE_RATE

__all__ = [
    "CYCLE_EXAMPLE",
    "IMPORT_NAME_CHARACTER",
    "IMPORT_NAME_PATTERN",
    "CycleQuery",
    "PhaseReadingPublic",
    "SeriesData",
    "SeriesImportForm",
    "SeriesList",
    "SeriesPublic",
    "SeriesRecordPublic",
    "import_name_problem",
]

#: a character an import's name may hold, and the whole name (the form, the CLI, the store)
IMPORT_NAME_CHARACTER = r"[A-Za-z0-9_.:-]"
IMPORT_NAME_PATTERN = rf"^{IMPORT_NAME_CHARACTER}{{1,200}}$"


def import_name_problem(name: str) -> str | None:
    """Why ``name`` cannot name an import, in words (the form showed the raw pattern)."""
    if re.fullmatch(IMPORT_NAME_PATTERN, name):
        return None
    return ("an import's name is 1 to 200 of the letters A-Z and a-z, digits and _ . : - "
            f"(no spaces or accents; e.g. pruefstand-2026-11); got {name[:60]!r}")


def _import_name(name: str) -> str:
    problem = import_name_problem(name)
    if problem is not None:  # the sentence as it is, without pydantic's "Value error, "
        raise PydanticCustomError("import_name", "{problem}", {"problem": problem})
    return name

#: a measured cycle in the format /simulate exports (the upload's example)
CYCLE_EXAMPLE = (
    "t [s],phase,x [m],P_pump [bar],P1 [bar],P2 [bar],Q_meter_B [l/min],Q_meter_C [l/min]\n"
    "0,working,0,24.3,21.7,1.18,27.8,22.7\n"
    "0.62,working,0.1,24.3,21.7,1.18,27.8,22.7\n"
    "1.24,working,0.2,24.3,21.7,1.18,27.8,22.7\n"
    "1.86,working,0.3,24.3,21.7,1.18,27.8,22.7\n"
    "2.48,working,0.4,24.3,21.7,1.18,27.8,22.7\n"
    "3.1,working,0.5,24.3,21.7,1.18,27.8,22.7\n"
    "3.11,return,0.5,3.2,1.2,2.0,28.0,-27.7\n"
    "3.57,return,0.4,3.2,1.2,2.0,28.0,-27.7\n"
    "4.03,return,0.3,3.2,1.2,2.0,28.0,-27.7\n"
    "4.49,return,0.2,3.2,1.2,2.0,28.0,-27.7\n"
    "4.95,return,0.1,3.2,1.2,2.0,28.0,-27.7\n"
    "5.41,return,0,3.2,1.2,2.0,28.0,-27.7\n"
)


class SeriesImportForm(UploadForm):
    """Form fields sent with a time-series file (``POST /rigs/{rig_id}/series``).

    The file part is let through and other unknown fields refused
    (:class:`~app.schemas.common.UploadForm`).
    """

    name: Annotated[str, AfterValidator(_import_name)] = Field(
        min_length=1, max_length=200, json_schema_extra={"pattern": IMPORT_NAME_PATTERN},
        description="Name of the import (the file or campaign): letters A-Z a-z, digits and "
        "_ . : - [-]", examples=["zema-cycles-1-100"])
    column_map: str | None = Field(
        default=None, max_length=20000,
        description="JSON object raw column → [channel, unit] for columns without a unit in "
        "their names, e.g. {\"PS1\": [\"P_pump\", \"bar\"]}; a raw signal (ADC counts, volts, "
        "mA) → [channel, unit, gain, offset], read as gain·raw + offset in unit; a column of "
        "record or stroke labels maps to [\"record\", \"-\"] or [\"phase\", \"-\"], one to "
        "leave out to [\"skip\", \"-\"] [-]",
        examples=['{"PS1": ["P_pump", "bar"], "FS1": ["Q_meter_B", "L/min"], '
                  '"run": ["record", "-"]}'])
    sample_rate: FiniteFloat | None = Field(
        default=None, gt=0, le=MAX_SAMPLE_RATE,
        description="Samples per second for a file without a time column [Hz]", examples=[1.0])
    started_at: MeasurementTime | None = Field(
        default=None,
        description="Clock time at which the file's t reads 0, ISO 8601 with zone, from "
        "1970 to a day ahead of the service's clock; each "
        "record is stored as measured at this plus its first sample's t (the file header's "
        "'# started_at = \"...\"' when not given; none when neither) [UTC]",
        examples=["2026-11-20T08:00:00Z"])
    time_in_name: str | None = Field(
        default=None, min_length=2, max_length=100,
        description="Read the start instead from the time the logger wrote into the file's "
        "name, a strptime format (%Y %y %m %d %H %I %M %S %f %j %p %b %z), e.g. "
        "'%m-%d-%Y-%I-%M-%S %p' for 'PS1_9-10-2019-4-37-01 PM.txt'; not with started_at [-]",
        examples=[None])
    zone: str | None = Field(
        default=None, max_length=10,
        description="Time zone of time_in_name when its format has no %z: Z, +02:00, -0400 "
        "[-]", examples=[None])


class SeriesPublic(PublicModel):
    """A stored record (without its samples; ``GET /series/{id}`` returns them)."""

    id: int = Field(description="Series identifier [-]", examples=[1])
    rig_id: int = Field(description="Rig the record was measured on [-]", examples=[1])
    name: str = Field(description="Name of the import [-]", examples=["zema-cycles-1-100"])
    record: str = Field(description="Record label within the import [-]", examples=["cycle-1"])
    sample_rate: float | None = Field(description="Uniform sampling rate, null when not "
                                      "uniform [Hz]", examples=[1.0])
    n_samples: int = Field(description="Number of samples [-]", examples=[60])
    measured: bool = Field(description="True for measured data, false for generated [-]",
                           examples=[True])
    units: dict[str, str] = Field(description="SI unit of every channel [-]",
                                  examples=[{"p_pump": "Pa", "q_work": "m^3/s"}])
    condition: dict[str, float] = Field(
        description="Constant operating condition: load [N], back_pressure [Pa], "
        "oil_temperature [°C], pump_speed [rad/s] — those known [SI]",
        examples=[{"oil_temperature": 45.2}])
    measured_at: Timestamp | None = Field(
        default=None, description="Clock time of the first sample, when the import stated "
        "it (null otherwise); a record read from the series is stored at this time [UTC]",
        examples=["2026-11-20T08:00:00Z"])
    created_at: Timestamp


class SeriesData(SeriesPublic):
    """A stored record with its samples, in SI units."""

    t: list[float] = Field(description="Sample times [s]", examples=[[0.0, 1.0, 2.0]])
    channels: dict[str, list[float]] = Field(
        description="Channel → values, in the unit of ``units`` [SI]",
        examples=[{"p_pump": [1.91e7, 1.91e7, 1.47e7]}])

    phase: list[str] | None = Field(
        default=None, description="Phase label of every sample ('working', 'return'), null "
        "when the file had no phase column [-]", examples=[["working", "working", "return"]])

    @classmethod
    def of(cls, row: Any) -> SeriesData:
        """Build from a stored row."""
        base = SeriesPublic.model_validate(row).model_dump()
        return cls(**base, t=row.data["t"], channels=row.data["channels"],
                   phase=row.data.get("phase"))


class SeriesList(Page[SeriesPublic]):
    """A page of stored records; an import's answer also says what the rig's model has no
    channel for."""

    notes: list[str] = Field(
        default_factory=list, description="On an import: channels stored that the rig's model "
        "has none of (a misspelt name in a column map?) [-]", examples=[[]])


class CycleQuery(BaseModel):
    """How to read a stored cycle as a record (``GET /series/{id}/record``): the rig version
    to diagnose against and condition values that override the series' own.  Query
    parameters are text, so numbers are parsed from it (not the JSON bodies' strict
    check); an unknown parameter is refused."""

    model_config = ConfigDict(extra="forbid")

    rig_version: int | None = Field(
        default=None, ge=1, le=MAX_ID,
        description="Version of the rig document whose stroke judges a completed stroke; the "
        "latest when null [-]", examples=[1])
    oil_temperature: FiniteFloat | None = Field(
        default=None, description="Oil temperature, when the series does not state it [°C]",
        examples=[40.0])
    load_force: FiniteFloat | None = Field(
        default=None, description="Load on the piston in the working phase [N]",
        examples=[4200.0])
    back_pressure: FiniteFloat | None = Field(
        default=None, description="Back-pressure of the load valve; 0 with a load force "
        "[Pa]", examples=[0.0])
    pump_speed: FiniteFloat | None = Field(
        default=None, description="Pump shaft speed [rad/s]", examples=[167.55])

    def condition(self) -> dict[str, float]:
        """The condition values given."""
        return {k: v for k, v in self.model_dump(exclude={"rig_version"}).items()
                if v is not None}


class PhaseReadingPublic(BaseModel):
    """One phase of a cycle as a rig reads it (diagnostics.cycle_readings)."""

    phase: str = Field(description="'working' or 'return' [-]", examples=["working"])
    completed: bool = Field(
        description="Whether the piston travelled at least 98 % of the stroke (or was still "
        "moving at its last sample, the end stop between two samples); a stalled or creeping "
        "stroke is read over the last half of the phase [-]", examples=[True])
    window_start: float = Field(description="First sample read [s]", examples=[0.314])
    window_end: float = Field(description="Last sample read [s]", examples=[2.791])
    travel: float = Field(description="Distance travelled in the phase [m]", examples=[0.4999])
    speed: float = Field(description="Steady speed (least-squares slope of the position over "
                         "the middle 80 % of the travel) or creep speed [m/s]",
                         examples=[0.1614])
    averages: dict[str, float] = Field(
        description="Channel → time average over the samples read [SI unit of the channel]",
        examples=[{"P1": 2.174e6}])


class SeriesRecordPublic(BaseModel):
    """A stored cycle read as the record ``POST /diagnose`` takes."""

    series_id: int = Field(description="Series identifier [-]", examples=[1])
    rig_id: int = Field(description="Rig the cycle was measured on [-]", examples=[1])
    rig_version: int = Field(description="Version of the rig document used [-]",
                             examples=[1])
    record: dict[str, Any] = Field(
        description="The record, in the form of `record` in POST /diagnose: condition and "
        "readings in SI units (each of its default instrument class) [-]",
        examples=[{"rig_id": 1, "condition": {"oil_temperature": 40.0, "load_force": 4200.0},
                   "p1": 2.174e6, "speed_work": 0.1614, "speed_return": 0.2177}])
    phases: list[PhaseReadingPublic] = Field(
        description="The phases read [-]",
        examples=[[{"phase": "working", "completed": True, "window_start": 0.314,
                    "window_end": 2.791, "travel": 0.4999, "speed": 0.1614,
                    "averages": {"P1": 2.174e6}}]])
    notes: list[str] = Field(
        description="What a reader must know (a stalled stroke, a reading left out, and "
        "why) [-]",
        examples=[["the working stroke stalled or crept (212.0 mm of 500.0 mm): read over "
                   "the last half of the phase"]])
