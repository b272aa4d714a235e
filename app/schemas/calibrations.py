"""Throttle-valve equivalence tables (paper 002, §2.7, Tables 2-3).

A leakage-simulating throttle valve is opened in steps; at each opening the bypass flow is
measured at a stated back-pressure and oil temperature, and converted to the equivalent
internal clearance of the component it bypasses (cylinder cc, valve cv).
"""

from __future__ import annotations

from functools import partial
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, StringConstraints, field_validator

from app.schemas.common import FiniteFloat, Page, PublicModel, RequestModel, not_nullable, reject_null
from app.schemas.times import Timestamp
from diagnostics.throttle_limits import (
    MAX_BACK_PRESSURE_PA,
    MAX_BYPASS_FLOW,
    MAX_OPENING_TURNS,
    TEMPERATURE_RANGE_C,
)

__all__ = [
    "MAX_CLEARANCE_M",
    "CalibrationCreate",
    "CalibrationList",
    "CalibrationPointIn",
    "CalibrationPointPublic",
    "CalibrationPublic",
    "CalibrationUpdate",
    "ClearanceAt",
    "ClearanceCurve",
    "ClearanceOrigin",
    "ClearanceSamples",
]

#: Where a table's clearance came from: given by the caller, or computed from the flow.
ClearanceOrigin = Literal["given", "computed"]
#: Largest equivalent clearance the store accepts, given or computed [m]: the rig
#: documents' plausibility bound of a clearance (a seal gone is ~0.3 mm); 7.3 "mm" typed
#: as metres' thousandths was stored under the former 10 mm (a technician's pass)
MAX_CLEARANCE_M = 2e-3
ThrottleLabel = Annotated[
    str, StringConstraints(min_length=1, max_length=16, pattern=r"^[A-Za-z0-9_-]+$")
]
ComponentName = Annotated[
    str, StringConstraints(min_length=1, max_length=64, pattern=r"^[a-z][a-z0-9_]*$")
]
#: the limits are the library's (diagnostics.throttle_limits), which a CalibrationTable in
#: Python refuses too: one definition (a library user's pass found them in the schema alone)
BackPressure = Annotated[FiniteFloat, Field(ge=0, le=MAX_BACK_PRESSURE_PA)]
#: the rig model's range of oil temperature [°C] (sim.rigs.circuits.pump_valve_cylinder)
Temperature = Annotated[FiniteFloat, Field(ge=TEMPERATURE_RANGE_C[0], le=TEMPERATURE_RANGE_C[1])]
#: the rig model's range of a throttle's opening [turn] (sim.components.throttle): a table
#: typed in degrees (0/45/90) was stored and interpolated (a technician's pass)
Opening = Annotated[FiniteFloat, Field(ge=0, le=MAX_OPENING_TURNS)]
BypassFlow = Annotated[FiniteFloat, Field(gt=0, lt=MAX_BYPASS_FLOW)]
Clearance = Annotated[FiniteFloat, Field(gt=0, lt=MAX_CLEARANCE_M)]
SourceNote = Annotated[str, StringConstraints(max_length=2000)]

_throttle = partial(
    Field, description="Throttle valve label on the rig's line diagram [-]", examples=["I", "H"]
)
_component = partial(
    Field,
    description="Component whose internal leakage the throttle simulates [-]",
    examples=["valve", "cylinder"],
)
_back_pressure = partial(
    Field, description="Back-pressure of the load control valve during the calibration, "
    "read as paper 002 states its loads: the equivalent load F = p·A2 on the piston (10 bar "
    "≙ 2.1 kN), the operating point the clearance is computed at; a record diagnosed at this "
    "condition states load_force = p·A2 (a record's back_pressure alone is a pressure in "
    "the outlet line, another operating point) [Pa]", examples=[1.0e6]
)
_temperature = partial(
    Field, description="Oil temperature during the calibration [°C]", examples=[40.0]
)
_source = partial(
    Field,
    description="Where the numbers come from (paper, lab notebook, date) [-]",
    examples=["lab notebook 2026-11-03, flowmeters B and C"],
)
_opening = partial(Field, description="Throttle opening from closed [turn]", examples=[1.5])
_flow = partial(
    Field, description="Measured equivalent leakage at this opening: the throttle's flow plus "
    "the component's own leak (meter C − A2·ẋ for the cylinder; meter B − meter C − "
    "(A1 − A2)·ẋ for the valve, the last term the area-difference flow of an unequal-area "
    "cylinder, zero on paper 002's; paper 002 §2.7, eqs. 10, 25-26), so the closed row is "
    "the existing clearance's leak; below the "
    "pump's delivery [m³/s] (l/min ÷ 60,000)", examples=[5.4e-5]
)
_clearance = partial(
    Field,
    description="Equivalent internal clearance: the concentric annular gap that passes the "
    "flow by the component's leakage law at the table's condition (a throttle is an "
    "orifice, so the equivalence holds at that load and temperature, not at others); null "
    "when not known yet, then computed from the flow; at most 2 mm [m]",
    examples=[62e-6],
)
_points = partial(
    Field,
    min_length=2,
    max_length=200,
    description="Rows of the table, any order; openings distinct; flows and clearances must "
    "not fall as the opening grows [-]",
    examples=[[
        {"opening_turns": 0.0, "bypass_flow_m3s": 8.6e-6, "clearance_m": 34e-6},
        {"opening_turns": 0.5, "bypass_flow_m3s": 1.3e-5, "clearance_m": 37e-6},
        {"opening_turns": 1.0, "bypass_flow_m3s": 2.7e-5, "clearance_m": None},
    ]],
)


class CalibrationPointIn(RequestModel):
    """One row of an equivalence table, as given."""

    opening_turns: Opening = _opening()
    bypass_flow_m3s: BypassFlow = _flow()
    clearance_m: Clearance | None = _clearance(default=None)


class CalibrationPointPublic(PublicModel):
    """One stored row of an equivalence table."""

    opening_turns: float = _opening()
    bypass_flow_m3s: float = _flow()
    clearance_m: float | None = _clearance(default=None)
    clearance_origin: ClearanceOrigin | None = Field(
        default=None,
        description="'given' by the caller, 'computed' from the bypass flow, null if unknown [-]",
        examples=["given"],
    )


class CalibrationCreate(RequestModel):
    """A new equivalence table for one throttle of a rig."""

    throttle: ThrottleLabel = _throttle()
    component: ComponentName = _component()
    back_pressure_pa: BackPressure = _back_pressure()
    temperature_c: Temperature = _temperature()
    source: SourceNote | None = _source(default=None)
    points: list[CalibrationPointIn] = _points()


_NOT_NULL = ("throttle", "component", "back_pressure_pa", "temperature_c", "points")


class CalibrationUpdate(RequestModel):
    """Changes to an equivalence table; fields left out stay; ``points`` replace all rows.

    ``source`` may be set to null (drop the note).
    """

    throttle: ThrottleLabel | None = _throttle(default=None)
    component: ComponentName | None = _component(default=None)
    back_pressure_pa: BackPressure | None = _back_pressure(default=None)
    temperature_c: Temperature | None = _temperature(default=None)
    source: SourceNote | None = _source(default=None)
    points: list[CalibrationPointIn] | None = _points(default=None)

    model_config = ConfigDict(json_schema_extra=not_nullable(*_NOT_NULL))

    _not_null = field_validator(*_NOT_NULL)(reject_null)


class ClearanceCurve(BaseModel):
    """Monotone curve opening → clearance, for interpolation between table rows."""

    method: Literal["pchip"] = Field(
        description="Interpolant: piecewise cubic Hermite, monotonicity-preserving "
        "(Fritsch & Carlson 1980) [-]",
        examples=["pchip"],
    )
    opening_turns: list[float] = Field(
        description="Knots: openings whose clearance is known [turn]",
        examples=[[0.0, 0.5, 1.0, 1.5, 2.0]],
    )
    clearance_m: list[float] = Field(
        description="Clearance at each knot [m]",
        examples=[[34e-6, 37e-6, 49e-6, 62e-6, 73e-6]],
    )


class CalibrationPublic(PublicModel):
    """A stored equivalence table with its interpolation curve."""

    id: int = Field(description="Calibration identifier [-]", examples=[1])
    rig_id: int = Field(description="Rig identifier [-]", examples=[1])
    rig_version: int | None = Field(
        default=None, description="The rig version whose document computed the table's "
        "clearances; null when none was computed (or not known: a table stored before "
        "revision 0013 on a rig with several versions) [-]", examples=[1])
    stale: bool = Field(
        default=False, description="Whether the computed clearances come from another "
        "rig version than the latest (a new seal length or oil moves them); an update, "
        "even an empty PATCH, computes them again with the latest [-]", examples=[False])
    throttle: str = _throttle()
    component: str = _component()
    back_pressure_pa: float = _back_pressure()
    temperature_c: float = _temperature()
    source: str | None = _source(default=None)
    points: list[CalibrationPointPublic] = Field(
        description="Rows of the table in order of opening [-]", examples=[[]]
    )
    curve: ClearanceCurve | None = Field(
        description="Interpolation curve; null when fewer than two clearances are known [-]",
        examples=[None],
    )
    created_at: Timestamp
    updated_at: Timestamp


class CalibrationList(Page[CalibrationPublic]):
    """A page of a rig's equivalence tables."""


class ClearanceAt(BaseModel):
    """The curve's clearance at one opening."""

    opening_turns: float = _opening()
    clearance_m: float = Field(
        description="Interpolated equivalent clearance [m]", examples=[55.2e-6]
    )


class ClearanceSamples(BaseModel):
    """Clearances interpolated on an equivalence table's curve."""

    calibration_id: int = Field(description="Calibration identifier [-]", examples=[1])
    component: str = _component()
    stale: bool = Field(
        default=False, description="Whether the table's computed clearances come from "
        "another rig version than the latest (its `stale`) [-]", examples=[False])
    samples: list[ClearanceAt] = Field(
        description="One sample per requested opening, in the order asked [-]",
        examples=[[{"opening_turns": 1.25, "clearance_m": 55.2e-6}]],
    )
