"""Sweeps: many fault scenarios of one rig, run as a job (grid or Latin hypercube)."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import BaseModel, Field, field_validator, model_validator

from app.schemas.common import MAX_ID, FiniteFloat, RequestModel
from app.schemas.simulate import ConditionSpec, check_fault

__all__ = ["CONDITION_NAMES", "RangeSpec", "SweepAccepted", "SweepRequest"]

#: Condition fields a sweep may vary, with their units.
CONDITION_NAMES: dict[str, str] = {
    "load": "N", "back_pressure": "Pa", "oil_temperature": "°C", "pump_speed": "rad/s",
}


class RangeSpec(RequestModel):
    """One swept factor: a parameter override or a condition field, between two values."""

    name: str = Field(
        min_length=3, max_length=64,
        description="A parameter override 'role.name' (in `parameters`) or a condition "
        "field load, back_pressure, oil_temperature, pump_speed (in `conditions`) [-]",
        examples=["cylinder.cc"],
    )
    low: FiniteFloat = Field(description="Lowest value, SI unit of the factor [unit]",
                             examples=[83e-6])
    high: FiniteFloat = Field(description="Highest value, SI unit of the factor [unit]",
                              examples=[160e-6])
    levels: int = Field(
        default=3, ge=1, le=100,
        description="Number of levels on a grid (ignored by a Latin hypercube) [-]",
        examples=[5],
    )
    log: bool = Field(
        default=False,
        description="Space the values evenly in log (needs low > 0) [-]", examples=[False],
    )

    @model_validator(mode="after")
    def _ordered(self) -> RangeSpec:
        if self.high < self.low:
            raise ValueError("high must not be below low")
        if self.log and not self.low > 0:
            raise ValueError("a log range needs low > 0")
        return self


class SweepRequest(RequestModel):
    """A set of scenarios: named faults × (grid or Latin hypercube over the factors)."""

    rig_id: int = Field(ge=1, le=MAX_ID, description="Rig identifier [-]", examples=[1])
    rig_version: int | None = Field(
        default=None, ge=1, le=MAX_ID,
        description="Version of the rig document; latest when null [-]",
        examples=[None],
    )
    faults: list[str] = Field(
        default_factory=lambda: ["healthy"], min_length=1, max_length=10,
        description="Named fault scenarios; every design point is run for each [-]",
        examples=[["healthy", "worn_spool"]],
    )
    parameters: list[RangeSpec] = Field(
        default_factory=list, max_length=8,
        description="Parameter overrides to vary, applied over the fault's; one a named fault "
        "sets itself is refused for that fault (its points would be another's) [-]",
        examples=[[{"name": "cylinder.cc", "low": 83e-6, "high": 160e-6, "levels": 4}]],
    )
    conditions: list[RangeSpec] = Field(
        default_factory=list, max_length=4,
        description="Condition fields to vary: load [N], back_pressure [Pa], oil_temperature "
        "[°C], pump_speed [rad/s] [-]",
        examples=[[{"name": "load", "low": 2100.0, "high": 6300.0, "levels": 3}]],
    )
    base_condition: ConditionSpec = Field(
        default_factory=ConditionSpec,
        description="Condition of the fields not varied; the rig's defaults where null [-]",
        examples=[{"oil_temperature": 40.0}],
    )
    design: Literal["grid", "lhs"] = Field(
        default="grid",
        description="'grid': every combination of the levels; 'lhs': `samples` points of a "
        "Latin hypercube over the factors' ranges [-]",
        examples=["grid"],
    )
    samples: int = Field(default=20, ge=1, le=5000,
                         description="Points of a Latin hypercube [-]", examples=[20])
    seed: int = Field(default=0, ge=0, description="Seed of the Latin hypercube [-]",
                      examples=[0])
    method: Literal["steady", "transient"] = Field(
        default="steady",
        description="'steady': the algebraic operating points (fast path); 'transient': a "
        "full cycle per point [-]",
        examples=["steady"],
    )

    @field_validator("faults")
    @classmethod
    def _known_faults(cls, values: list[str]) -> list[str]:
        for value in values:
            check_fault(value)
        if len(set(values)) != len(values):
            raise ValueError("each fault once")
        return values

    @field_validator("conditions")
    @classmethod
    def _condition_names(cls, values: list[RangeSpec]) -> list[RangeSpec]:
        for value in values:
            if value.name not in CONDITION_NAMES:
                raise ValueError(f"{value.name!r} is not a condition field "
                                 f"({', '.join(CONDITION_NAMES)})")
        return values

    @model_validator(mode="after")
    def _distinct_factors(self) -> SweepRequest:
        names = [r.name for r in (*self.parameters, *self.conditions)]
        if len(set(names)) != len(names):
            raise ValueError("each factor once")
        return self

    def n_points(self) -> int:
        """Number of scenarios the request asks for [-]."""
        factors = [*self.parameters, *self.conditions]
        if not factors:
            per_fault = 1
        elif self.design == "lhs":
            per_fault = self.samples
        else:
            per_fault = math.prod(r.levels for r in factors)
        return per_fault * len(self.faults)


class SweepAccepted(BaseModel):
    """A sweep accepted as a job; follow it at ``/jobs/{job_id}``."""

    job_id: str = Field(description="Job identifier (UUID) [-]",
                        examples=["1b4e28ba-2fa1-11d2-883f-0016d3cca427"])
    status: str = Field(description="Job state at acceptance [-]", examples=["queued"])
    n_points: int = Field(ge=1, description="Scenarios to run [-]", examples=[24])
    executor: str = Field(description="Where the points run: 'processes' or 'dask' [-]",
                          examples=["processes"])
