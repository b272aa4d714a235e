"""Console pages: a rig's measured series, one series plotted (a cycle also read as a
record, diagnosed from the diagnose form), and the discrepancy workflow on the series
chosen (a job, followed on its page, its report shown when done).

The records are those ``POST /rigs/{id}/series`` and ``hydrodiag import`` stored, or the
page's own import form (the same service and validation: a file, a column map for a
logger's layout, a sample rate, the clock time at t = 0); the check
is ``POST /discrepancy`` with ``series_ids`` (:func:`app.services.discrepancy.plan_discrepancy`,
the same validation and the same job), so a record without phase labels or of another rig
gets the API's field-naming error on the page.  Importing and starting a check need a key
of scope ``write``.
"""

from __future__ import annotations

import re
from typing import Annotated, Any
from urllib.parse import urlencode

from fastapi import File, Form, Path, Query, Request, Response, UploadFile
from fastapi.responses import HTMLResponse
from pydantic import ValidationError
from starlette.concurrency import run_in_threadpool

from app.api.deps import ExecutorsDep, RigsDep, SessionDep
from app.console.charts import leak_chart, series_charts
from app.console.numbers import decimal_text
from app.console.routing import ConsoleKeyDep, new_router, write_refusal
from app.console.web import SECURITY_HEADERS, page, redirect
from app.errors import first_problem, status_for
from app.schemas.common import MAX_ID
from app.schemas.discrepancy import DiscrepancyForm
from app.schemas.pump_leak import PumpLeakRequest
from app.schemas.series import IMPORT_NAME_CHARACTER, CycleQuery, SeriesImportForm
from app.services import jobs as job_service
from app.services import rigs as rig_service
from app.services import series as series_service
from app.services.discrepancy import plan_discrepancy, submit_discrepancy
from app.services.pump_leak import pump_leak, segments
from app.services.series_record import READING_UNITS, stored_cycle_record
from diagnostics.real.relaxation import ZEMA_RELAXATION
from sim.errors import ConflictError, HydrodiagError, InputError

__all__ = ["router"]

router = new_router()

#: Records listed on one page of the series list [-].
PAGE = 100


def _list(request: Request, session: Any, rig: int | None, offset: int,
          error: dict[str, Any] | None = None, status_code: int = 200,
          entered: dict[str, str] | None = None) -> Response:
    rigs, _ = rig_service.rig_choices(session)
    chosen = rig if rig is not None else (rigs[0].id if rigs else None)
    items, total = (series_service.list_series(session, chosen, limit=PAGE, offset=offset)
                    if chosen is not None else ([], 0))
    jobs, _ = job_service.list_jobs(session, limit=20, offset=0, kind="discrepancy")
    mine = [j for j in jobs if (j.params or {}).get("rig_id") == chosen]
    cycle = next((r.cycle for r in rigs if r.id == chosen), True)
    return page(request, "series.html", status_code=status_code, rigs=rigs, rig=chosen,
                items=items, total=total, offset=offset, page_size=PAGE, jobs=mine,
                error=error, cycle=cycle, relaxation=ZEMA_RELAXATION, entered=entered)


@router.get("/series")
def series_list(request: Request, session: SessionDep, _key: ConsoleKeyDep,
                rig: Annotated[int | None, Query(ge=1, le=MAX_ID)] = None,
                offset: Annotated[int, Query(ge=0)] = 0) -> Response:
    """The rig's stored records (a page of them), the form that checks the ticked ones, and
    the rig's recent checks."""
    return _list(request, session, rig, offset)


@router.get("/series/import")
@router.get("/series/check")
def series_forms(_key: ConsoleKeyDep) -> Response:
    """The import and check forms post here; a reload of the address after a failed post,
    or a bookmark, goes back to the page that holds them (it read "import" as a series id
    and answered 422)."""
    return redirect("/console/series")


@router.get("/series/pump-leak")
def pump_leak_page(request: Request, session: SessionDep, rigs: RigsDep,
                   executors: ExecutorsDep, _key: ConsoleKeyDep,
                   rig: Annotated[int, Query(ge=1, le=MAX_ID)],
                   baseline: Annotated[str, Query(max_length=60000)] = "") -> Response:
    """The pump's leak per stored cycle of a rig without a cylinder and where it steps
    (``POST /rigs/{id}/pump-leak`` with its defaults, against the stated baseline's cycles
    when given); nothing is stored, so any console key may read it.  What the estimate
    refuses (a rig whose cycles lack the pump pressure and flow, a batch of one class
    without a baseline) is shown with the field it names."""
    answer, error, status_code = None, None, 200
    try:
        ids = None
        if baseline.strip():
            try:
                ids = [int(x) for x in baseline.split(",")]
            except ValueError:
                raise InputError("give the baseline's series ids comma-separated, e.g. "
                                 "3,4,5", field="baseline_series_ids") from None
        try:
            request_ = PumpLeakRequest(baseline_series_ids=ids)
        except ValidationError as exc:
            raise first_problem(exc.errors()) from None
        answer = pump_leak(session, rigs, rig, request_, executor=executors.get())
    except HydrodiagError as exc:
        error = {"type": type(exc).__name__, "message": exc.message, "field": exc.field}
        status_code = status_for(exc)
    return page(request, "pump_leak.html", status_code=status_code, rig=rig, answer=answer,
                error=error, baseline=baseline,
                segments=segments(answer) if answer is not None else [],
                chart=leak_chart(answer) if answer is not None else None)


#: the condition a stored cycle may lack, and the page states: field → unit
STATED_CONDITION = {"oil_temperature": "°C", "load_force": "N"}


def stated_condition(oil_temperature: str, load_force: str) -> dict[str, float]:
    """The condition a user states for a stored cycle (blank: the series' own), read as
    ``GET /series/{id}/record`` reads its query (:class:`~app.schemas.series.CycleQuery`):
    a logger file without an oil-temperature column could be imported but never read as
    a record from the console."""
    given = {k: decimal_text(v, field=k) for k, v in (("oil_temperature", oil_temperature),
                                                      ("load_force", load_force)) if v.strip()}
    try:
        return CycleQuery.model_validate(given).condition()
    except ValidationError as exc:
        raise first_problem(exc.errors()) from None


@router.get("/series/{series_id}")
def series_one(request: Request, session: SessionDep, rigs: RigsDep, _key: ConsoleKeyDep,
               series_id: Annotated[int, Path(ge=1, le=MAX_ID)],
               oil_temperature: Annotated[str, Query(max_length=40)] = "",
               load_force: Annotated[str, Query(max_length=40)] = "") -> Response:
    """One stored record: what it is, its channels against time, and a cycle's readings
    as a record (``GET /series/{id}/record``) with a link that diagnoses them, or why it
    cannot be read as one; the oil temperature and load it lacks can be stated here."""
    row = series_service.get_series(session, series_id)
    record = series_service.as_record(row)
    read, unread = None, None
    stated = {"oil_temperature": oil_temperature, "load_force": load_force}
    try:
        read = stored_cycle_record(session, rigs, series_id,
                                   condition=stated_condition(oil_temperature, load_force))
    except InputError as exc:  # no phases, no position, a circuit without a cylinder ...
        unread = {"type": type(exc).__name__, "message": exc.message, "field": exc.field}
    query = urlencode({k: v for k, v in stated.items() if v.strip()})
    return page(request, "series_one.html", row=row, charts=series_charts(record),
                phases=sorted(set(record.phase.tolist())) if record.phase is not None else [],
                read=read, unread=unread, units=READING_UNITS, stated=stated,
                stated_units=STATED_CONDITION, stated_query=f"&{query}" if query else "",
                channel_notes=series_service.rig_channels(session, row.rig_id).notes([row]))


@router.post("/series/check")
async def check(request: Request, session: SessionDep, rigs: RigsDep, _key: ConsoleKeyDep,
                rig: Annotated[int, Form(ge=1, le=MAX_ID)],
                series: Annotated[list[int] | None, Form()] = None,
                store: Annotated[bool, Form()] = False) -> Response:
    """Start the discrepancy workflow on the ticked records; go to the job's page."""
    refusal = write_refusal(_key, "a check may store a new rig version and")
    if refusal is not None:
        return await run_in_threadpool(_list, request, session, rig, 0, refusal, 403)
    try:
        if not series:
            raise InputError("tick at least one record", field="series_ids")
        try:
            form = DiscrepancyForm(rig_id=rig, store=store,
                                   series_ids=",".join(str(i) for i in series))
        except ValidationError as exc:  # e.g. more records ticked than a check takes
            raise first_problem(exc.errors()) from None
        plan = await run_in_threadpool(plan_discrepancy, session, rigs, form, None)
    except HydrodiagError as exc:
        error = {"type": type(exc).__name__, "message": exc.message, "field": exc.field}
        return await run_in_threadpool(_list, request, session, rig, 0, error, status_for(exc))
    job = submit_discrepancy(request.app.state.jobs, request.app.state.sessions, form, plan)
    return redirect(f"/console/jobs/{job.id}?follow=true")


def _import_name(name: str, filename: str | None) -> str:
    """The import's name as given, else the file's name with the characters a name may
    not hold replaced by '-'."""
    if name.strip():
        return name.strip()
    return re.sub(f"(?!{IMPORT_NAME_CHARACTER}).", "-", filename or "")[:200] or "upload"


@router.post("/series/import")
async def import_file(request: Request, session: SessionDep, _key: ConsoleKeyDep,
                      rig: Annotated[int, Form(ge=1, le=MAX_ID)],
                      name: Annotated[str, Form(max_length=200)] = "",
                      column_map: Annotated[str, Form(max_length=20000)] = "",
                      sample_rate: Annotated[str, Form(max_length=40)] = "",
                      started_at: Annotated[str, Form(max_length=64)] = "",
                      time_in_name: Annotated[str, Form(max_length=100)] = "",
                      zone: Annotated[str, Form(max_length=10)] = "",
                      file: Annotated[UploadFile | None, File()] = None) -> Response:
    """Import a file's records as the rig's series (``POST /rigs/{id}/series``); go to the
    record's page (one record) or the rig's list; a bad file or field shows the list again
    with the error naming it and the fields as entered, nothing stored."""
    entered = {"name": name, "column_map": column_map, "sample_rate": sample_rate,
               "started_at": started_at, "time_in_name": time_in_name, "zone": zone}
    refusal = write_refusal(_key, "importing a file")
    if refusal is not None:
        return await run_in_threadpool(_list, request, session, rig, 0, refusal, 403, entered)
    try:
        if file is None or not file.filename:
            raise InputError("choose a file to import", field="file")
        try:
            form = SeriesImportForm.model_validate({
                "name": _import_name(name, file.filename), "column_map": column_map or None,
                "sample_rate": decimal_text(sample_rate, field="sample_rate") or None,
                "started_at": started_at.strip() or None,
                "time_in_name": time_in_name.strip() or None, "zone": zone.strip() or None})
        except ValidationError as exc:
            raise first_problem(exc.errors()) from None
        content = await file.read(series_service.MAX_SERIES_BYTES + 1)
        rows, _notes = await run_in_threadpool(  # the series page shows the notes
            series_service.import_series, session, rig, form.name, content,
            column_map=series_service.parse_column_map(form.column_map),
            sample_rate=form.sample_rate, started_at=form.started_at, filename=file.filename,
            time_in_name=form.time_in_name, zone=form.zone)
    except HydrodiagError as exc:
        error = {"type": type(exc).__name__, "message": exc.message, "field": exc.field}
        return await run_in_threadpool(_list, request, session, rig, 0, error, status_for(exc),
                                       entered)
    if len(rows) == 1:
        return redirect(f"/console/series/{rows[0].id}")
    return redirect(f"/console/series?rig={rig}")


@router.get("/jobs")
def jobs_page(request: Request, session: SessionDep, _key: ConsoleKeyDep) -> Response:
    """The latest jobs of every kind (discrepancy checks, sweeps, re-diagnoses), newest
    first, each linked to its page: a sweep posted over HTTP could not be found from the
    console at all (a maintenance planner's pass)."""
    jobs, total = job_service.list_jobs(session, limit=JOBS_SHOWN, offset=0, results=False)
    return page(request, "jobs.html", jobs=jobs, total=total)


#: jobs the console's list shows
JOBS_SHOWN = 100


@router.get("/jobs/{job_id}")
def job_page(request: Request, session: SessionDep, _key: ConsoleKeyDep,
             job_id: Annotated[str, Path(max_length=36)],
             follow: Annotated[bool, Query()] = False) -> Response:
    """A job's state, with a button that cancels it while it runs; ``follow``: the page
    reloads itself every :data:`FOLLOW_S` until the job is done (a started check goes
    there), else a link checks again; a finished check's verdict, named effects and a link
    to its report.

    It reloaded every 2 s always: each reload put a keyboard's focus and a screen reader
    back at the top, so the cancel button, 13 Tabs down, was never reached (an
    accessibility pass); following is now asked for, and stopped, by a link first in the
    page's main part."""
    return _job_page(request, session, job_id, follow=follow)


#: how often a followed job's page reloads itself [s]
FOLLOW_S = 5


def _job_page(request: Request, session: SessionDep, job_id: str,
              error: dict[str, Any] | None = None, status_code: int = 200,
              follow: bool = False) -> Response:
    job = job_service.get_job(session, job_id)
    done = job.status in ("succeeded", "failed", "cancelled")
    return page(request, "job.html", status_code, job=job, done=done, result=job.result or {},
                error=error, follow=follow and not done, follow_s=FOLLOW_S)


@router.post("/jobs/{job_id}/cancel")
def cancel_job(request: Request, session: SessionDep, _key: ConsoleKeyDep,
               job_id: Annotated[str, Path(max_length=36)]) -> Response:
    """Cancel the job (``POST /jobs/{id}/cancel``: a queued one at once, a running one at
    its next progress report) and show its page again; a key of scope ``write`` or above."""
    refusal = write_refusal(_key, "cancelling a job")
    if refusal is not None:
        return _job_page(request, session, job_id, refusal, 403)
    try:
        job_service.cancel_job(session, job_id)
    except ConflictError as exc:
        error = {"type": type(exc).__name__, "message": exc.message, "field": exc.field}
        return _job_page(request, session, job_id, error, 409)
    # followed until it stops at its next progress report
    return redirect(f"/console/jobs/{job_id}?follow=true")


@router.get("/jobs/{job_id}/report")
def job_report(session: SessionDep, _key: ConsoleKeyDep,
               job_id: Annotated[str, Path(max_length=36)]) -> Response:
    """The finished job's self-contained report page (inline SVG, no script, no style
    element: it keeps the console's Content-Security-Policy), here with the console's
    style sheet and a way back to the job (it rendered in the browser's default serif
    with no rules and no links: a console pass)."""
    job = job_service.get_job(session, job_id)
    html = (job.result or {}).get("html") if job.status == "succeeded" else None
    if not isinstance(html, str):
        raise InputError(f"job {job_id} has no report (status {job.status!r})", field="job_id")
    html = html.replace("</head>", "<link rel='stylesheet' href='/console/static/console.css'>"
                        "</head>", 1)
    html = html.replace("<body>", f"<body><main><p class='muted'><a href='/console/jobs/"
                        f"{job.id}'>← the job</a> · <a href='/console'>console</a></p>", 1)
    html = html.replace("</body>", "</main></body>", 1)
    return HTMLResponse(html, headers=SECURITY_HEADERS)
