"""Fault scenarios: a stored rig, parameter overrides or a named fault, a condition."""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial
from typing import Any, ClassVar, Literal

from pydantic import BaseModel, Field, PositiveFloat, field_validator

from app.schemas.common import MAX_ID, FiniteFloat, RequestModel
from sim.rigs.assembly import MAX_PUMP_SPEED
from sim.scenarios import FAULTS, fault_help

__all__ = [
    "ConditionSpec",
    "SimulateRequest",
    "SimulationPublic",
    "SolverPublic",
    "TimeseriesFormat",
    "TimeseriesTable",
]

#: How the time series of a transient run comes back.
TimeseriesFormat = Literal["json", "csv", "parquet"]

_rig_id = partial(Field, ge=1, le=MAX_ID, description="Rig identifier [-]", examples=[1])
_rig_version = partial(
    Field, ge=1, description="Version of the rig document; the latest when null [-]",
    examples=[None],
)
_fault = partial(
    Field,
    description=f"Named fault scenario of sim.scenarios ({fault_help()}); its overrides "
    "come first, `overrides` are applied over them [-]",
    examples=["worn_spool"],
)
_overrides = partial(
    Field,
    description="Parameter overrides 'role.name' → value in the parameter's SI unit, e.g. "
    "valve.cv [m], cylinder.cc [m], pump.Rlp [Pa·s/m³], relief.Pset [Pa] [SI unit of each]",
    examples=[{"valve.cv": 60e-6}],
)


def check_fault(value: str | None) -> str | None:
    """Refuse a fault name that :mod:`sim.scenarios` does not know."""
    if value is not None and value not in FAULTS:
        raise ValueError(f"unknown fault {value!r} (known: {', '.join(FAULTS)})")
    return value


class ConditionSpec(RequestModel):
    """Operating condition; a field left out takes the rig document's default."""

    synonyms: ClassVar[Mapping[str, str]] = {"load_force": "load"}

    load: FiniteFloat | None = Field(
        default=None, description="Load force resisting extension, working phase [N]",
        examples=[4200.0],
    )
    back_pressure: FiniteFloat | None = Field(
        default=None, description="Back-pressure of the load valve in the outlet line [Pa]",
        examples=[0.0],
    )
    oil_temperature: FiniteFloat | None = Field(
        default=None, description="Oil temperature [°C]", examples=[40.0],
    )
    pump_speed: FiniteFloat | None = Field(
        default=None, gt=0, le=MAX_PUMP_SPEED,
        description="Pump shaft speed; the rig's when null [rad/s]",
        examples=[None],
    )


class SimulateRequest(RequestModel):
    """One run of a fault scenario."""

    rig_id: int = _rig_id()
    rig_version: int | None = _rig_version(default=None)
    fault: str | None = _fault(default=None)
    overrides: dict[str, FiniteFloat] = _overrides(default_factory=dict)
    condition: ConditionSpec = Field(
        default_factory=ConditionSpec, description="Operating condition [-]",
        examples=[{"load": 4200.0, "oil_temperature": 40.0}],
    )
    method: Literal["transient", "steady"] = Field(
        default="transient",
        description="'transient': integrate a working + return cycle (see `solver`); 'steady': the "
        "algebraic operating points of both phases, ~1000× faster, no time series [-]",
        examples=["transient"],
    )
    timeseries: TimeseriesFormat | None = Field(
        default=None,
        description="Return the transient time series: 'json' inside the answer, 'csv' or "
        "'parquet' as the answer's body with the summary in its header/metadata [-]",
        examples=[None],
    )
    solver: Literal["rodas4", "ros2"] = Field(
        default="rodas4",
        description="Integrator of the transient: 'rodas4' (fourth order, dense output, "
        "sampling, error estimate) or 'ros2' (second order, one row per step) [-]",
        examples=["rodas4"],
    )
    rtol: FiniteFloat | None = Field(
        default=None, gt=1e-8, le=1e-1,
        description="Relative tolerance of the transient integrator; null (default): "
        "noise-accurate, the tolerance is chosen so that the estimated error meets "
        "`noise_fraction` of `noise` (ros2: 1e-3); given, the run is at this tolerance and "
        "its error is only estimated (rodas4) [-]",
        examples=[None],
    )
    sample_rate: float | None = Field(
        default=None, ge=1.0, le=100_000,
        description="Time series on a grid of this rate from t = 0, from the dense output "
        "(rodas4 only; 1 Hz to 100 kHz); null: one row per accepted solver step [Hz]",
        examples=[1000.0],
    )
    noise: dict[str, PositiveFloat] = Field(
        default_factory=dict,
        description="Sensor noise σ per output name, in the output's unit; outputs not named "
        "take the default of their unit: velocity 3.2e-4 m/s, pressure 25e3 Pa, flow "
        "2.33e-6 m³/s, position 1e-5 m [output unit]",
        examples=[{"v": 3.2e-4, "P_pump": 25e3}],
    )
    noise_fraction: dict[str, PositiveFloat] = Field(
        default_factory=dict,
        description="Error target per output name as a fraction of its σ; default 0.3 for "
        "velocities, 0.1 otherwise [-]",
        examples=[{"v": 0.3}],
    )

    _fault_known = field_validator("fault")(check_fault)


class TimeseriesTable(BaseModel):
    """A time series as columns and rows; units in the column names."""

    columns: list[str] = Field(
        description="Column names with units in brackets, 't [s]' first [-]",
        examples=[["t [s]", "phase", "P_pump [Pa]"]],
    )
    data: list[list[Any]] = Field(
        description="Rows, one per accepted solver step, in column order [unit of each column]",
        examples=[[[0.0, "working", 0.0]]],
    )


class SolverPublic(BaseModel):
    """How a transient was integrated and the error it reached."""

    method: str = Field(description="'rodas4' or 'ros2' [-]", examples=["rodas4"])
    rtol: float = Field(description="Relative tolerance of the returned run [-]",
                        examples=[3e-5])
    rejected: int = Field(description="Rejected steps, both phases [-]", examples=[12])
    rhs_evaluations: int = Field(
        description="Right-hand-side evaluations, Jacobians included (0: not counted) [-]",
        examples=[27000])
    error_sigma: dict[str, float] | None = Field(
        description="Estimated error per output in units of its noise σ (maximum over the "
        "output times, from a companion run at 10·rtol); null without estimate [-]",
        examples=[{"v": 0.15, "P_pump": 0.01}])
    target_sigma: dict[str, float] | None = Field(
        description="Error target per output in units of its σ [-]", examples=[{"v": 0.3}])
    sigma: dict[str, float] | None = Field(
        description="Noise σ of each controlled output [output unit]",
        examples=[{"v": 3.2e-4}])
    switch_time_error: float | None = Field(
        description="Estimated error of the working → return switch time [s]",
        examples=[1e-9])


class SimulationPublic(BaseModel):
    """Result of a run: the phase summaries, optionally the time series."""

    rig_id: int = _rig_id()
    rig_version: int = Field(ge=1, description="Version of the rig document used [-]",
                             examples=[1])
    fault: str | None = _fault(default=None)
    overrides: dict[str, float] = _overrides()
    condition: dict[str, float | None] = Field(
        description="Condition used: load [N], back_pressure [Pa], oil_temperature [°C], "
        "pump_speed [rad/s] (the rig's where the request gave none) [-]",
        examples=[{"load": 4200.0, "back_pressure": 0.0, "oil_temperature": 40.0,
                   "pump_speed": 167.55}],
    )
    method: str = Field(description="'transient' or 'steady' [-]", examples=["transient"])
    summary: dict[str, float | None] = Field(
        description="Phase averages 'phase.quantity [unit]' and 'velocity_ratio [-]'; null "
        "where undefined: a stalled phase's duration, and the ratio when the return stroke "
        "stalls (working speed over zero); a stalled working stroke with a moving return "
        "gives ratio 0 [unit in each key]",
        examples=[{"working.speed [m/s]": 0.170, "velocity_ratio [-]": 0.80}],
    )
    completed: dict[str, bool] = Field(
        description="Whether each phase reached its end of stroke [-]",
        examples=[{"working": True, "return": True}],
    )
    steps: dict[str, int] = Field(
        description="Accepted solver steps per phase (empty for 'steady') [-]",
        examples=[{"working": 1800, "return": 1750}],
    )
    solver: SolverPublic | None = Field(
        default=None, description="Integration of the transient; null for 'steady' [-]",
        examples=[{"method": "rodas4", "rtol": 3e-5, "rejected": 12, "rhs_evaluations": 27000,
                   "error_sigma": {"v": 0.15}, "target_sigma": {"v": 0.3},
                   "sigma": {"v": 3.2e-4}, "switch_time_error": 1e-9}],
    )
    timeseries: TimeseriesTable | None = Field(
        default=None, description="The time series when asked for as 'json' [-]",
        examples=[None],
    )
    notes: list[str] = Field(
        default_factory=list, description="What a reader must know that the numbers do not "
        "say: a stroke that did not reach its end (stalled or crept; its averages are the "
        "settled last half of the phase), a gauge pressure below vacuum anywhere in the "
        "phase (the model has no cavitation), by output; the same whether or not the time "
        "series is asked for [-]",
        examples=[[]])
