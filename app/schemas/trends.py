"""Trends of a rig's components over its diagnosis history."""

from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import BaseModel, Field

__all__ = ["ComponentTrend", "TrendComponent", "TrendPoint", "TrendsPublic"]

#: Components with a trend: clearance of cylinder and valve [m], slip coefficient of the pump.
TrendComponent = Literal["cylinder", "valve", "pump"]


class TrendPoint(BaseModel):
    """One diagnosis in a component's series."""

    diagnosis_id: int = Field(description="Diagnosis identifier [-]", examples=[12])
    measured_at: datetime = Field(description="When the record was taken [UTC]",
                                  examples=["2026-11-22T08:30:00Z"])
    rig_version: int = Field(description="Version of the rig document used [-]", examples=[1])
    value: float = Field(description="Estimate [unit of the series]", examples=[5.9e-5])
    low: float | None = Field(description="Lower end of its 95 % interval [unit of the series]",
                              examples=[5.6e-5])
    high: float | None = Field(description="Upper end of its 95 % interval [unit of the series]",
                               examples=[6.2e-5])
    probability: float | None = Field(
        description="Probability that this component is worn, alone or in a pair: the sum "
        "over the hypotheses that name it (a valve at 0.82 beside valve+pump at 0.18 is 1.0) "
        "[1]", examples=[0.75])


class ComponentTrend(BaseModel):
    """A component's series, its robust slope and the time left to a threshold."""

    component: TrendComponent = Field(description="Component [-]", examples=["valve"])
    quantity: str = Field(description="'cc', 'cv' (clearance) or 'Cs' (pump slip) [-]",
                          examples=["cv"])
    unit: str = Field(description="Unit of the series [-]", examples=["m"])
    points: list[TrendPoint] = Field(
        description="The series, oldest first: the points made with the latest version's "
        "parameters, thinned evenly to at most `max_points` (the first and the latest kept; "
        "the slope and forecast use every point) [-]", examples=[[]])
    points_total: int = Field(
        ge=0, description="How many points the series has, all used by the slope and the "
        "forecast (more than `points` holds when thinned) [-]", examples=[0])
    slope: float | None = Field(
        description="Theil-Sen slope; null with fewer than 3 visit times [unit/s]",
        examples=[1.2e-12])
    slope_low: float | None = Field(description="Lower end of the slope's 95 % interval [unit/s]",
                                    examples=[4e-13])
    slope_high: float | None = Field(
        description="Upper end of the slope's 95 % interval [unit/s]", examples=[2e-12])
    threshold: float = Field(description="Threshold of the forecast [unit of the series]",
                             examples=[5.44e-5])
    threshold_source: str = Field(
        description="'given', or how the default was derived from the rig [-]",
        examples=["default: 1.6 × nominal clearance (leakage ×4.1, 'severe')"])
    status: Literal["worsening", "not_worsening", "crossed", "insufficient_data",
                    "stale"] = Field(
        description="Which case of diagnostics.trends.forecast_threshold applies, or "
        "'stale': at least 3 later diagnoses of the rig gave no estimate of this component "
        "(its hypothesis did not fit their readings), so nothing is forecast [-]",
        examples=["worsening"])
    time_left_s: float | None = Field(
        description="Time from the last visit to the crossing on the fitted line; null when "
        "never or unknown (also when the slope's 95 % interval reaches 'not worsening') [s]",
        examples=[3.1e7])
    time_left_low_s: float | None = Field(
        description="Earliest crossing the slope and level intervals allow, from the last "
        "visit; null when never or unknown [s]", examples=[1.9e7])
    time_left_high_s: float | None = Field(
        description="Latest crossing the slope and level intervals allow, from the last "
        "visit; null when never or unknown [s]",
        examples=[9.3e7])
    crossing_at: datetime | None = Field(
        description="Date of the crossing on the fitted line; for 'crossed', when the line "
        "crossed the threshold [UTC]", examples=["2027-11-22T08:30:00Z"])
    later_diagnoses: int = Field(
        default=0, ge=0, description="Diagnoses of the rig after the last point (in the "
        "window) that gave no estimate of this component [-]", examples=[0])
    left_out: int = Field(
        default=0, ge=0, description="Points of older rig versions whose parameters differ "
        "from the latest version's (commissioning, a rebuild), left out of `points` and the "
        "fit: their estimates were made against another document [-]", examples=[0])
    left_out_versions: list[int] = Field(
        default_factory=list, description="Those versions [-]", examples=[[]])
    unexplained: int = Field(
        default=0, ge=0, description="Points of diagnoses whose readings the rig model and "
        "its fault library did not explain (top 'unexplained'), left out of `points` and the "
        "fit: an estimate through a model the readings contradict estimates nothing [-]",
        examples=[0])
    step_at: datetime | None = Field(
        default=None, description="When the level stepped last (a contamination event, a "
        "part changed, wear that sped up: a straight line read such a step as steady wear); "
        "null when no step was found. With one, the slope and forecast use the points "
        "after it [UTC]", examples=[None])
    step_size: float | None = Field(
        default=None, description="That step [unit of the series]", examples=[None])
    points_fitted: int = Field(
        default=0, ge=0, description="Points the slope and the forecast were fitted to: "
        "all of `points_total`, or those after the step [-]", examples=[3])
    message: str = Field(description="One sentence for the report [-]",
                         examples=["cv reaches 54.42 µm in 360 days"])


class TrendsPublic(BaseModel):
    """Trends of a rig's components."""

    rig_id: int = Field(description="Rig identifier [-]", examples=[1])
    components: list[ComponentTrend] = Field(
        description="One trend per component with history (or the one asked for) [-]",
        examples=[[]])
