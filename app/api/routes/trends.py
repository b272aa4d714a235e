"""Trends of a rig's components: ``GET /rigs/{rig_id}/trends``."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Response

from app.api.deps import ReadAccess, RigsDep, SessionDep
from app.api.rendered import rendered
from app.api.routes.rigs import RigId
from app.schemas.common import ERROR_RESPONSES
from app.schemas.times import SinceTime, UntilTime
from app.schemas.trends import ComponentTrend, TrendComponent, TrendPoint, TrendsPublic
from app.services.trends import ComponentTrendOut, component_trends

__all__ = ["router"]

#: Points of each series in an answer unless asked otherwise, and the most one may ask for.
DEFAULT_TREND_POINTS = 2000
MAX_TREND_POINTS = 100_000

router = APIRouter(tags=["trends"], dependencies=[ReadAccess], responses=ERROR_RESPONSES)


def _public(trend: ComponentTrendOut) -> ComponentTrend:
    return ComponentTrend(
        component=trend.component,  # type: ignore[arg-type]
        quantity=trend.quantity, unit=trend.unit,
        points=[TrendPoint(diagnosis_id=p.diagnosis_id, measured_at=p.measured_at,
                           rig_version=p.rig_version, value=p.value, low=p.low, high=p.high,
                           probability=p.probability) for p in trend.points],
        slope=trend.slope, slope_low=trend.slope_low, slope_high=trend.slope_high,
        threshold=trend.threshold, threshold_source=trend.threshold_source,
        status=trend.status,  # type: ignore[arg-type]
        time_left_s=trend.time_left_s, time_left_low_s=trend.time_left_low_s,
        time_left_high_s=trend.time_left_high_s, crossing_at=trend.crossing_at,
        message=trend.message, later_diagnoses=trend.later_diagnoses,
        points_total=trend.points_total,
        left_out=trend.left_out, left_out_versions=trend.left_out_versions,
        unexplained=trend.unexplained, step_at=trend.step_at, step_size=trend.step_size,
        points_fitted=trend.points_fitted,
    )


@router.get("/rigs/{rig_id}/trends", summary="Trends of a rig's components from its history",
            response_model=TrendsPublic)
def trends(
    rig_id: RigId,
    session: SessionDep,
    rigs: RigsDep,
    component: Annotated[TrendComponent | None, Query(
        description="Only this component [-]", examples=["valve"])] = None,
    threshold: Annotated[float | None, Query(
        description="Threshold for `component`, in its unit; a default derived from the rig "
        "when left out [m or 1]", examples=[6.0e-5])] = None,
    since: Annotated[SinceTime | None, Query(
        description="Only diagnoses of records taken at or after this time (a date alone: "
        "the start of that day) [UTC]",
        examples=["2026-01-01T00:00:00Z"])] = None,
    until: Annotated[UntilTime | None, Query(
        description="Only diagnoses of records taken at or before this time (a date alone: "
        "the end of that day) [UTC]",
        examples=["2026-12-31T23:59:59Z"])] = None,
    max_points: Annotated[int, Query(
        ge=2, le=MAX_TREND_POINTS, description="Most points of each series in the answer, "
        "thinned evenly (the first and the latest kept); the slope and forecast use every "
        "point [-]", examples=[DEFAULT_TREND_POINTS])] = DEFAULT_TREND_POINTS,
) -> Response:
    """Per component: the series of estimates, the Theil-Sen slope with its interval, and
    the time left until the threshold with its interval (``diagnostics.trends``)."""
    found = component_trends(session, rigs, rig_id, component=component, threshold=threshold,
                             since=since, until=until, max_points=max_points)
    return rendered(TrendsPublic(rig_id=rig_id, components=[_public(t) for t in found]))
