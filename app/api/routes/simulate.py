"""One run of a fault scenario: ``POST /simulate``."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Response

from app.api.deps import ReadAccess, RigsDep, SessionDep, SettingsDep
from app.schemas.common import ERROR_RESPONSES
from app.schemas.simulate import SimulateRequest, SimulationPublic
from app.services.simulation import (
    limits_of,
    public_of,
    simulate,
    timeseries_csv,
    timeseries_parquet,
)

__all__ = ["router"]

router = APIRouter(tags=["simulation"], dependencies=[ReadAccess], responses=ERROR_RESPONSES)

PARQUET_MEDIA_TYPE = "application/vnd.apache.parquet"

_FILE_RESPONSES: dict[int | str, dict[str, Any]] = {
    200: {
        "description": "The summary as JSON, or with `timeseries` 'csv'/'parquet' the time "
        "series as a file (summary in its '# key = value' header lines or Parquet metadata)",
        # the files as strings and bytes, so a generated client reads them as what they
        # are rather than as JSON (it crashed on the CSV: an API client's pass)
        "content": {"text/csv": {"schema": {"type": "string"}},
                    PARQUET_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary"}}},
    },
}


@router.post("/simulate", summary="Simulate a fault scenario on a stored rig",
             response_model=SimulationPublic, responses=_FILE_RESPONSES)
def simulate_scenario(body: SimulateRequest, session: SessionDep, rigs: RigsDep,
                      settings: SettingsDep) -> Any:
    """Run one working + return cycle (or the steady operating points) of the scenario.

    A transient that needs more than the configured solver limits (steps, simulated time,
    wall clock) is answered 422 with the reason.
    """
    outcome = simulate(session, rigs, body, limits_of(settings), max_rows=settings.sim_max_rows)
    if body.timeseries == "csv":
        return Response(timeseries_csv(outcome), media_type="text/csv",
                        headers={"Content-Disposition": 'attachment; filename="simulation.csv"'})
    if body.timeseries == "parquet":
        return Response(timeseries_parquet(outcome), media_type=PARQUET_MEDIA_TYPE,
                        headers={"Content-Disposition":
                                 'attachment; filename="simulation.parquet"'})
    return public_of(outcome, table=body.timeseries == "json")
