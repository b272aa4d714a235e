"""Commissioning a rig from healthy records: ``POST /rigs/{rig_id}/commission``."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field

from app.schemas.common import RequestModel
from app.schemas.diagnose import MeasurementIn

__all__ = ["CommissionRequest", "CommissionResponse", "CommissionedParameterPublic"]

#: a healthy record of the reference rig at 40 °C and 2.1 kN (its steady readings; the
#: diagnosis example's worn-valve record would move the valve's land length by -81 %, a
#: fit that is refused unless `beyond_prior`)
_HEALTHY_RECORD: dict[str, Any] = {
    "rig_id": 1, "measured_at": "2026-11-22T08:30:00Z",
    "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
    "pump_pressure": 14.56e5, "p1": 11.92e5, "p2": 1.227e5, "flow_B": 4.642e-4,
    "flow_C": 4.556e-4, "speed_work": 0.2064, "speed_return": 0.2195,
}

_PARAMETERS = ["cylinder.Lc", "valve.Ls", "valve.K", "cylinder.Fu", "cylinder.Kf", "pump.Rlp"]


class CommissionRequest(RequestModel):
    """Healthy records of the rig as built, at several loads and oil temperatures."""

    records: list[MeasurementIn] = Field(
        min_length=1, max_length=100,
        description="Records of the healthy rig; each names this rig (the latest version is "
        "commissioned: a record stating another `rig_version` is refused) [-]",
        examples=[[_HEALTHY_RECORD]])
    parameters: list[str] | None = Field(
        default=None, min_length=1,
        description="Which uncertain parameters to fit, of " + ", ".join(_PARAMETERS)
        + "; all when null [-]", examples=[_PARAMETERS])
    comment: str | None = Field(default=None, max_length=500,
                                description="Comment for the new rig version [-]",
                                examples=["commissioned after installation"])
    beyond_prior: bool = Field(
        default=False, description="Store a fit that moves a parameter more than 3 prior σ "
        "from the document's value (refused otherwise: the records may hold wear the fit "
        "would absorb, masking it in every later diagnosis) [-]", examples=[False])


class CommissionedParameterPublic(BaseModel):
    """One fitted parameter of the rig."""

    name: str = Field(description="Parameter, role.name [-]", examples=["cylinder.Lc"])
    description: str = Field(description="What it is [-]",
                             examples=["sealing length of the piston"])
    unit: str = Field(description="SI unit of before, value, low and high [-]", examples=["m"])
    before: float = Field(description="Value in the commissioned document [unit]",
                          examples=[0.01231])
    value: float = Field(description="Fitted value [unit]", examples=[0.0160])
    low: float = Field(description="Lower end of the 95 % interval [unit]", examples=[0.0152])
    high: float = Field(description="Upper end of the 95 % interval [unit]", examples=[0.0168])
    prior_sd: float = Field(description="Standard deviation of ln θ before the records [-]",
                            examples=[0.5])
    posterior_sd: float = Field(
        description="Standard deviation of ln θ after them, linearised (what `identifiable` "
        "reads); a pinned parameter's 95 % interval also carries the parameters the records "
        "left open beyond the linearisation, so it may be wider or skewed [-]",
        examples=[0.025])
    prior_shift: float = Field(
        description="How far the fit moved it from the document's value, in prior standard "
        "deviations of ln θ; beyond 3 the fit is not stored unless `beyond_prior` [-]",
        examples=[0.6])
    identifiable: bool = Field(
        description="Whether the records pinned it down (posterior σ ≤ half the prior σ); "
        "only these are written into the new version [-]", examples=[True])
    correlated_with: list[str] = Field(
        description="Parameters it trades off against (|correlation| ≥ 0.8) [-]",
        examples=[[]])


class CommissionResponse(BaseModel):
    """The fit and the rig version it was stored as."""

    rig_id: int = Field(ge=1, description="Rig identifier [-]", examples=[1])
    from_version: int = Field(ge=1, description="Version that was commissioned [-]",
                              examples=[1])
    version: int = Field(ge=1, description="New version holding the fitted values; the "
                         "commissioned one when nothing was stored [-]", examples=[2])
    stored: bool = Field(description="Whether a new version was stored: not when every "
                         "pinned-down parameter's 95 % interval holds the document's value "
                         "(the records confirm it; a version that changes nothing the records "
                         "can tell would split the rig's history and trends) [-]",
                         examples=[True])
    parameters: list[CommissionedParameterPublic] = Field(
        description="Every fitted parameter, pinned down or not [-]", examples=[[]])
    chi2: float = Field(description="χ² of the readings at the estimate [-]", examples=[27.0])
    dof: float = Field(description="Degrees of freedom of its test: readings less the "
                       "effective number of fitted parameters [-]", examples=[43.3])
    chi2_limit: float | None = Field(
        description="χ² limit at the 1 % level; a fit above it is refused (422 naming the "
        "record that disagrees most); null when there is no degree of freedom [-]",
        examples=[67.8])
    n_observations: int = Field(ge=1, description="Readings used [-]", examples=[48])
    n_records: int = Field(ge=1, description="Records used [-]", examples=[6])
    statements: list[str] = Field(
        description="What the records could not pin down, and why [-]", examples=[[]])
