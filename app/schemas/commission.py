"""Commissioning a rig from healthy records: ``POST /rigs/{rig_id}/commission``."""

from __future__ import annotations

from pydantic import BaseModel, Field

from app.schemas.common import RequestModel
from app.schemas.diagnose import _EXAMPLE_RECORD, MeasurementIn

__all__ = ["CommissionRequest", "CommissionResponse", "CommissionedParameterPublic"]

_PARAMETERS = ["cylinder.Lc", "valve.Ls", "valve.K", "cylinder.Fu", "cylinder.Kf", "pump.Rlp"]


class CommissionRequest(RequestModel):
    """Healthy records of the rig as built, at several loads and oil temperatures."""

    records: list[MeasurementIn] = Field(
        min_length=1, max_length=100,
        description="Records of the healthy rig; each names this rig (its `rig_version` is "
        "ignored: the latest version is commissioned) [-]", examples=[[_EXAMPLE_RECORD]])
    parameters: list[str] | None = Field(
        default=None, min_length=1,
        description="Which uncertain parameters to fit, of " + ", ".join(_PARAMETERS)
        + "; all when null [-]", examples=[_PARAMETERS])
    comment: str | None = Field(default=None, max_length=500,
                                description="Comment for the new rig version [-]",
                                examples=["commissioned after installation"])


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
    posterior_sd: float = Field(description="Standard deviation of ln θ after them [-]",
                                examples=[0.025])
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
    version: int = Field(ge=1, description="New version holding the fitted values [-]",
                         examples=[2])
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
