"""Stored history read back: measurement records and their diagnoses."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import AwareDatetime, Field

from app.schemas.common import Page, PublicModel

__all__ = [
    "BlamedComponent",
    "StoredDiagnosisList",
    "StoredDiagnosisPublic",
    "StoredEstimatePublic",
    "StoredMeasurementList",
    "StoredMeasurementPublic",
]

#: what a stored diagnosis's top hypothesis blames: one component, a pair of the fault
#: library (:data:`diagnostics.hypotheses.HYPOTHESES`), ``healthy`` or ``unexplained``
BlamedComponent = Literal["healthy", "unexplained", "cylinder", "valve", "pump", "relief",
                          "cylinder+valve", "cylinder+pump", "valve+pump"]

_RECORD_EXAMPLE: dict[str, Any] = {
    "rig_id": 1, "measured_at": "2026-11-22T08:30:00+00:00",
    "condition": {"oil_temperature": {"value": 40.0}, "load_force": {"value": 2100.0}},
    "p1": {"value": 1190000.0}, "flow_B": {"value": 4.44e-4, "u": 2.6e-6},
}


class StoredMeasurementPublic(PublicModel):
    """A stored measurement record, as it was posted to ``/diagnose``."""

    id: int = Field(description="Measurement identifier [-]", examples=[31])
    rig_id: int = Field(description="Rig identifier [-]", examples=[1])
    measured_at: AwareDatetime = Field(description="When the readings were taken [UTC]",
                                       examples=["2026-11-22T08:30:00Z"])
    record: dict[str, Any] = Field(
        description="The record as posted (readings in SI units: pressures [Pa], flows "
        "[m³/s], speeds [m/s], durations [s], temperature [°C], force [N]), its time "
        "filled in [-]", examples=[_RECORD_EXAMPLE])
    diagnosis_ids: list[int] = Field(
        description="Stored diagnoses made from this record: its own and the joint ones it "
        "took part in (kept with another record of the visit) [-]", examples=[[12]])
    created_at: AwareDatetime = Field(description="When it was stored [UTC]",
                                      examples=["2026-11-22T08:31:02Z"])


class StoredMeasurementList(Page[StoredMeasurementPublic]):
    """A page of stored measurement records."""

    next_after_id: int | None = Field(
        default=None, description="With `after_id`: the cursor to read on from (this page's "
        "last id, or `after_id` when none is new); null without it [-]", examples=[None])


class StoredEstimatePublic(PublicModel):
    """A stored per-component estimate of a diagnosis (the trend series): the fields of the
    ``POST /diagnose`` answer's estimate, and the trend's value columns."""

    component: str = Field(description="Component [-]", examples=["valve"])
    quantity: str | None = Field(
        default=None, description="'cc' or 'cv' (equivalent clearance), 'Cs' (pump slip "
        "coefficient); null for diagnoses stored before the answer's estimates were kept [-]",
        examples=["cv"])
    unit: str | None = Field(default=None, description="Unit of value, low and high [-]",
                             examples=["m"])
    value: float | None = Field(default=None, description="Estimate [unit]",
                                examples=[5.9e-5])
    low: float | None = Field(default=None, description="Lower end of the 95 % interval "
                              "[unit]", examples=[5.6e-5])
    high: float | None = Field(default=None, description="Upper end of the 95 % interval "
                               "[unit]", examples=[6.2e-5])
    source: str | None = Field(
        default=None, description="'direct', 'hypothesis' or 'profile', as in the answer of "
        "POST /diagnose [-]", examples=["direct"])
    probability: float | None = Field(
        description="Probability that this component is worn, alone or in a pair; 0 when "
        "the readings were unexplained (diagnoses stored before 2026-11-28: its single-fault "
        "hypothesis's alone; until 2026-11-30 an unexplained one's sum as well) [1]",
        examples=[0.75])
    clearance_m: float | None = Field(
        description="Estimated equivalent clearance; null for the pump [m]", examples=[5.9e-5])
    slip_coefficient: float | None = Field(
        description="Estimated pump slip coefficient Cs; null for the others [1]",
        examples=[None])


class StoredDiagnosisPublic(PublicModel):
    """A stored diagnosis with the record it was made from."""

    id: int = Field(description="Diagnosis identifier [-]", examples=[12])
    measurement_id: int = Field(description="Measurement the result is kept with [-]",
                                examples=[31])
    measurement_ids: list[int] = Field(
        description="Every measurement the diagnosis was made from: one, or each record of "
        "a joint diagnosis (joint diagnoses stored before revision 0008 name only the one "
        "they are kept with) [-]", examples=[[31]])
    rig_id: int = Field(description="Rig identifier [-]", examples=[1])
    rig_version: int = Field(description="Version of the rig document used [-]",
                             examples=[1])
    measured_at: AwareDatetime = Field(description="Time of the record [UTC]",
                                       examples=["2026-11-22T08:30:00Z"])
    top: str | None = Field(
        default=None, description="Most probable hypothesis, 'unexplained' when nothing "
        "fits, as POST /diagnose answered it [-]", examples=["valve"])
    explained: bool | None = Field(
        default=None, description="Whether the rig model and its fault library explain the "
        "readings, as POST /diagnose answered it [-]", examples=[True])
    component: str | None = Field(
        description="Component(s) the top hypothesis blames, '+'-joined; 'healthy' [-]",
        examples=["valve"])
    probability: float | None = Field(description="Probability of the top hypothesis [1]",
                                      examples=[0.75])
    estimates: list[StoredEstimatePublic] = Field(
        description="Per-component estimates kept for the trends [-]", examples=[[]])
    result: dict[str, Any] = Field(
        description="The full diagnosis as answered by POST /diagnose; SI units stated per "
        "field [-]", examples=[{"top": "valve", "hypotheses": []}])
    created_at: AwareDatetime = Field(description="When it was stored [UTC]",
                                      examples=["2026-11-22T08:31:02Z"])
    superseded_by: int | None = Field(
        default=None, description="The diagnosis of the same records against a later rig "
        "version that replaced this one (POST /rigs/{id}/rediagnose); null while this one "
        "is current. Listings and trends read current diagnoses [-]", examples=[None])
    supersedes: int | None = Field(
        default=None, description="The diagnosis this one replaced, when it was made by a "
        "re-diagnosis; null otherwise [-]", examples=[None])


class StoredDiagnosisList(Page[StoredDiagnosisPublic]):
    """A page of stored diagnoses."""

    next_after_id: int | None = Field(
        default=None, description="With `after_id`: the cursor to read on from (this page's "
        "last id, or `after_id` when none is new); null without it [-]", examples=[None])
