"""Measured time series of a rig: import a file, list and read back the records."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, File, Form, Path, Query, Response, UploadFile, status

from app.api.deps import (
    AdminKeyDep,
    ExecutorsDep,
    PageDep,
    ReadAccess,
    RigsDep,
    SessionDep,
    WriteKeyDep,
)
from app.api.rendered import rendered
from app.schemas.common import ERROR_RESPONSES, MAX_ID
from app.schemas.pump_leak import PumpLeakRequest, PumpLeakResponse
from app.schemas.series import (
    CYCLE_EXAMPLE,
    CycleQuery,
    PhaseReadingPublic,
    SeriesData,
    SeriesImportForm,
    SeriesList,
    SeriesPublic,
    SeriesRecordPublic,
)
from app.services import series as service
from app.services.pump_leak import pump_leak
from app.services.series_record import stored_cycle_record

__all__ = ["router"]

router = APIRouter(tags=["measured series"], dependencies=[ReadAccess],
                   responses=ERROR_RESPONSES)

RigId = Annotated[int, Path(ge=1, le=MAX_ID, description="Rig identifier [-]", examples=[1])]
SeriesId = Annotated[int, Path(ge=1, le=MAX_ID, description="Series identifier [-]",
                                     examples=[1])]


@router.post("/rigs/{rig_id}/series", status_code=status.HTTP_201_CREATED,
             summary="Import measured time series as measurements of a rig")
def import_series(
    rig_id: RigId,
    form: Annotated[SeriesImportForm, Form()],
    file: Annotated[UploadFile, File(
        description="CSV or Parquet, one row per sample: 't [s]' (or a sample rate), "
        "channels 'name [unit]' (or a column map), optional 'record' and 'phase' [-]",
        examples=[CYCLE_EXAMPLE])],
    session: SessionDep,
    _key: WriteKeyDep,
    response: Response,
) -> SeriesList:
    """Read every record of the file (diagnostics.timeseries) and store each one; a bad
    column refuses the whole file (422 naming it) and stores nothing."""
    content = file.file.read(service.MAX_SERIES_BYTES + 1)
    rows, notes = service.import_series(session, rig_id, form.name, content,
                                 column_map=service.parse_column_map(form.column_map),
                                 sample_rate=form.sample_rate, started_at=form.started_at,
                                 filename=file.filename, time_in_name=form.time_in_name,
                                 zone=form.zone)
    response.headers["Location"] = f"/rigs/{rig_id}/series"
    return SeriesList(items=[SeriesPublic.model_validate(r) for r in rows], total=len(rows),
                      limit=max(1, len(rows)), offset=0, notes=notes)


@router.get("/rigs/{rig_id}/series", summary="List the rig's measured records")
def list_series(rig_id: RigId, session: SessionDep, page: PageDep) -> SeriesList:
    """Return a page of the rig's records (without samples), in order of import."""
    rows, total = service.list_series(session, rig_id, limit=page.limit, offset=page.offset)
    return SeriesList(items=[SeriesPublic.model_validate(r) for r in rows], total=total,
                      limit=page.limit, offset=page.offset)


@router.get("/series/{series_id}", summary="Get a measured record with its samples",
            response_model=SeriesData)
def get_series(series_id: SeriesId, session: SessionDep) -> Response:
    """Return the record with its samples in SI units."""
    return rendered(SeriesData.of(service.get_series(session, series_id)))


@router.delete("/series/{series_id}", status_code=status.HTTP_204_NO_CONTENT,
               response_class=Response, summary="Delete a measured record")
def delete_series(series_id: SeriesId, session: SessionDep, _key: AdminKeyDep) -> None:
    """Delete the stored record (a wrong import, or to delete its rig); diagnoses of cycles
    read from it stay in the history.  Needs a key of scope ``admin``."""
    service.delete_series(session, series_id)


@router.get("/series/{series_id}/record",
            summary="Read a measured cycle as the record POST /diagnose takes")
def series_record(series_id: SeriesId, query: Annotated[CycleQuery, Query()],
                  session: SessionDep, rigs: RigsDep) -> SeriesRecordPublic:
    """Read the stored cycle phase by phase as the rig's meters read it
    (diagnostics.cycle_readings): working-phase pressures and flows averaged over the middle
    80 % of the travel, each stroke's steady speed; a stalled stroke over the last half of
    its phase; a series without a phase column has its phases read off the position (a
    note says so).  Post ``record`` to ``/diagnose`` as it is; the query's condition values
    override the series'.  Nothing is stored."""
    read = stored_cycle_record(session, rigs, series_id, rig_version=query.rig_version,
                               condition=query.condition())
    return SeriesRecordPublic(
        series_id=series_id, rig_id=read.rig.rig_id, rig_version=read.rig.version,
        record=read.body, notes=list(read.readings.notes),
        phases=[PhaseReadingPublic(phase=p.phase, completed=p.completed,
                                   window_start=p.window[0], window_end=p.window[1],
                                   travel=p.travel, speed=p.speed, averages=p.averages)
                for p in read.readings.phases])


@router.post("/rigs/{rig_id}/pump-leak",
             summary="The pump's leak per stored cycle of a rig without a cylinder, and its "
             "shifts")
def estimate_pump_leak(rig_id: RigId, body: PumpLeakRequest, session: SessionDep,
                       rigs: RigsDep, executors: ExecutorsDep,
                       _key: WriteKeyDep) -> PumpLeakResponse:
    """Each stored cycle's settled working plateaus against a healthy reference at its own
    oil temperature and pressure: the orifice leak size K of Δq = K·√Δp + λ·Δp/μ (paper 000
    eq. 6 form, diagnostics.real.monitor), whether it leaks, and the steps of K over the
    cycles in time order.  Nothing is stored; a cycle without the pump pressure, working
    flow and oil temperature, or without a working plateau, is a 422 naming its series.
    A key with the write scope is needed, as for every POST but /simulate and /diagnose.
    The estimate runs on the sweeps' executor, so /health is not kept waiting."""
    return pump_leak(session, rigs, rig_id, body, executor=executors.get())
