"""Console pages: diagnose (paste a record or upload a CSV), a diagnosis, history, trends."""

from __future__ import annotations

import asyncio
import json
import re
from collections.abc import Sequence
from datetime import datetime
from functools import partial
from typing import Annotated, Any

import yaml
from fastapi import File, Form, Path, Query, Request, Response, UploadFile
from pydantic import ValidationError
from sqlalchemy.orm import Session

from app.api.deps import RigsDep, SessionDep
from app.console.pages_series import stated_condition
from app.console.routing import ConsoleKeyDep, filter_error, new_router, write_refusal
from app.console.views import HistoryPage, diagnosis_view, history_page, trend_views
from app.console.web import page, redirect
from app.db.base import utcnow
from app.errors import ServiceUnavailableError, first_problem, status_for
from app.limits import check_count, check_file
from app.schemas.common import MAX_ID
from app.schemas.diagnose import DiagnoseRequest
from app.schemas.record_csv import record_rows
from app.schemas.times import SinceTime, UntilTime, filter_time
from app.services import rigs as rig_service
from app.services.diagnosis import (
    STORE_CONFLICT,
    GroupPlan,
    add_outcomes,
    outcome_of,
    plan_groups,
)
from app.services.diagnosis_pool import DiagnosisPool
from app.services.group_commit import GroupCommitter
from app.services.series_record import stored_cycle_record
from sim.errors import HydrodiagError, InputError
from sim.yaml_loader import load_yaml

__all__ = ["parse_records", "router"]

router = new_router()


#: Largest pasted text or uploaded CSV [byte].
MAX_INPUT_BYTES = 1024 * 1024


def _csv_records(content: bytes, lines: list[int]) -> list[dict[str, Any]]:
    """Records from a CSV: one per row; ``condition.load_force`` style names nest;
    ``lines`` gets each row's line in the file."""
    check_file(content, MAX_INPUT_BYTES)
    records = record_rows(content, field="file", lines=lines)
    if not records:
        raise InputError("the CSV has no rows", field="file")
    if any(key.startswith("t [") for key in records[0]):
        # a logged cycle (a /simulate export): "unknown fields 'record', 't [s]' …" told
        # nothing of where it goes (a console pass)
        raise InputError("this is a measured time series (a 't [...]' column), not a table "
                         "of records: import it on the Measured page (/console/series), "
                         "then diagnose the stored cycle from its page — or "
                         "`hydrodiag diagnose FILE --rig ID` reads it as it is", field="file")
    return records


def _in_file(exc: HydrodiagError, lines: Sequence[int]) -> HydrodiagError:
    """``exc`` on a record of an uploaded CSV named by the row's line in the file and its
    column ("records[3].p1" named no place in it: a console pass); else ``exc``.  Every
    refused row of its ``details`` likewise (the page named the first bad row only, the
    next after a second upload: a maintenance planner's pass)."""
    def placed(field: str | None, message: str) -> tuple[str | None, str]:
        where = re.fullmatch(r"records\[(\d+)\]\.?(.*)", field or "")
        if where is None or int(where.group(1)) >= len(lines):
            return field, message
        column = f", column {where.group(2)}" if where.group(2) else ""
        return "file", f"line {lines[int(where.group(1))]}{column}: {message}"

    field, message = placed(exc.field, exc.message.replace("every one is in details",
                                                           "each listed below"))
    out = type(exc)(message, field=field)
    if exc.details:
        out.details = [{"field": f, "message": m} for f, m in
                       (placed(d["field"], str(d["message"])) for d in exc.details)]
    return out


def _all_problems(exc: ValidationError) -> InputError:
    """The first of pydantic's problems, every one in its ``details``."""
    first = first_problem(exc.errors())
    if len(exc.errors()) > 1:
        each = [first_problem([err]) for err in exc.errors()]
        first = InputError(f"{first.message} (and {len(each) - 1} more refused: each listed "
                           "below)", field=first.field)
        first.details = [{"field": e.field, "message": e.message} for e in each]
    return first


def parse_records(text: str, content: bytes | None, lines: list[int] | None = None
                  ) -> DiagnoseRequest:
    """The diagnose request of a pasted JSON/YAML document or an uploaded CSV.

    A pasted document is a record, or a request body of ``POST /diagnose`` (``record`` or
    ``records``, ``joint``); a CSV is a batch of records diagnosed each alone.

    Raises
    ------
    InputError
        Nothing given, unreadable text, or a record the API would refuse (``field`` as
        the API names it).
    """
    if content is not None and text.strip():
        raise InputError("give a pasted record or a CSV file, not both (the file would be "
                         "diagnosed and the text left out)", field="document")
    lines = [] if lines is None else lines  # each CSV row's line in the file
    if content is not None:
        if not content.strip():
            raise InputError("the file is empty", field="file")
        document: Any = {"records": _csv_records(content, lines)}
    elif text.strip():
        if len(text) > MAX_INPUT_BYTES:
            raise InputError(f"at most {MAX_INPUT_BYTES} characters", field="document")
        try:
            document = load_yaml(text)
        except (yaml.constructor.ConstructorError,  # a key given twice, a bad tag
                yaml.composer.ComposerError) as exc:    # aliases expanding beyond bounds
            raise InputError(f"{exc.problem} ({exc.problem_mark})" if exc.problem_mark
                             else str(exc.problem), field="document") from None
        except yaml.YAMLError as exc:
            raise InputError(f"neither JSON nor YAML: {exc}", field="document") from None
        if not isinstance(document, dict):
            raise InputError("give a record (a mapping) or a request body", field="document")
        if "store" in document and document["store"] is not True:
            raise InputError("the console stores every diagnosis it shows; leave out "
                             "'store' (POST /diagnose with store: false answers without "
                             "storing)", field="store")
        if not {"record", "records"} & set(document):
            document = {"record": document}
    else:
        raise InputError("paste a record or choose a CSV file", field="document")
    try:
        return DiagnoseRequest.model_validate(json.loads(json.dumps(document, default=str)))
    except ValidationError as exc:
        raise _in_file(_all_problems(exc), lines) from None


def _form(request: Request, session: Any, *, status_code: int = 200, text: str = "",
          error: dict[str, Any] | None = None) -> Response:
    rows = [r for r in rig_service.rig_choices(session)[0] if r.cycle]  # can be diagnosed
    return page(request, "diagnose.html", status_code=status_code, rigs=rows, text=text,
                error=error)


@router.get("/diagnose")
def diagnose_form(request: Request, session: SessionDep, rigs: RigsDep, _key: ConsoleKeyDep,
                  series: Annotated[int | None, Query(ge=1, le=MAX_ID)] = None,
                  oil_temperature: Annotated[str, Query(max_length=40)] = "",
                  load_force: Annotated[str, Query(max_length=40)] = "") -> Response:
    """The form: paste a record (JSON or YAML) or upload a CSV of records; with ``series``,
    filled with that stored cycle's record (``GET /series/{id}/record``), read with the
    oil temperature and load the series page stated for it, if any."""
    if series is None:
        return _form(request, session)
    try:
        body = stored_cycle_record(session, rigs, series, condition=stated_condition(
            oil_temperature, load_force)).body
    except HydrodiagError as exc:
        error = {"type": type(exc).__name__, "message": exc.message,
                 "field": "series" if exc.field == "series_id" else exc.field}
        return _form(request, session, status_code=status_for(exc), error=error)
    return _form(request, session, text=json.dumps(body, indent=2))


def _plan(request: Request, session: Session, text: str, content: bytes | None,
          lines: list[int]) -> tuple[DiagnoseRequest, list[GroupPlan], datetime]:
    """Parse the pasted document or CSV and resolve its rigs (in a thread: it reads the
    store); ``now`` is the time of records that give none; ``lines`` gets a CSV's rows'
    lines."""
    body, now = parse_records(text, content, lines), utcnow()
    # the API's batch limit: the console stored 300 records in one request where the API
    # refuses 101 (a security review's pass)
    check_count(len(body.items()), request.app.state.settings.max_batch_records,
                what="records", field="records", setting="max_batch_records")
    return body, plan_groups(session, request.app.state.rigs, body, now), now


@router.post("/diagnose")
async def diagnose(request: Request, session: SessionDep, _key: ConsoleKeyDep,
                   document: Annotated[str, Form()] = "",
                   file: Annotated[UploadFile | None, File()] = None) -> Response:
    """Diagnose and store; show the result, or the form again with the error.

    The diagnoses are computed by the service's diagnosis processes and stored by its group
    commit, as ``POST /diagnose`` does (:mod:`app.api.routes.diagnose`), so that a console
    diagnosis never holds the interpreter lock of the event loop that answers ``/health``.
    Storing needs a key of scope ``write``: a read key gets the form again with a 403.
    """
    pool: DiagnosisPool = request.app.state.diagnosis_pool
    refusal = write_refusal(_key, "storing a diagnosis")
    if refusal is not None:
        return await pool.in_thread(partial(_form, request, session, status_code=403,
                                             text=document, error=refusal))
    content = (await file.read(MAX_INPUT_BYTES + 1)
               if file is not None and file.filename else None)
    lines: list[int] = []
    try:
        with pool.admit():
            body, plans, now = await pool.in_thread(partial(_plan, request, session, document,
                                                       content, lines))
            computed = await asyncio.gather(*(pool.compute(plan) for plan in plans))
            outcomes = [outcome_of(plan, result)
                        for plan, result in zip(plans, computed, strict=True)]
            writer: GroupCommitter = request.app.state.diagnosis_writer
            await writer.write(lambda s: add_outcomes(s, body, outcomes, now),
                               conflict=STORE_CONFLICT)
    except ServiceUnavailableError:  # busy or not ready: the console's 503 page
        raise
    except HydrodiagError as raised:
        exc = _in_file(raised, lines)
        error = {"type": type(exc).__name__, "message": exc.message, "field": exc.field,
                 "details": [d["message"] for d in (exc.details or [])[1:]]}
        return await pool.in_thread(partial(_form, request, session,
                                            status_code=status_for(exc), text=document,
                                            error=error))
    if len(outcomes) == 1:
        return redirect(f"/console/diagnoses/{outcomes[0].diagnosis_id}")
    return redirect(f"/console/history?rig={outcomes[0].resolved.rig_id}")


@router.get("/diagnoses/{diagnosis_id}")
def diagnosis(request: Request, session: SessionDep, _key: ConsoleKeyDep,
              diagnosis_id: Annotated[int, Path(ge=1, le=MAX_ID)]) -> Response:
    """One stored diagnosis: probabilities, readings, estimates, what cannot be separated."""
    return page(request, "diagnosis.html", view=diagnosis_view(session, diagnosis_id))


def _stamp(value: datetime | None) -> str:
    return "" if value is None else value.isoformat()


def _time(text: str, field: str) -> datetime | None:
    """A filter's time (:func:`~app.schemas.times.filter_time`): blank for none; a date
    alone is the start of that day (UTC) for ``since``, its end for ``until``, as the API
    reads them (the console read ``until=2026-10-02`` as that day's 00:00 and found
    nothing of it)."""
    return filter_time(text, SinceTime if field == "since" else UntilTime, field)


def _rig(text: str) -> int | None:
    """A filter's rig id: blank for all."""
    if not text.strip():
        return None
    if not text.strip().isdigit() or int(text) < 1:
        raise InputError("the rig id must be a whole number ≥ 1", field="rig")
    return int(text)


@router.get("/history")
def history(request: Request, session: SessionDep, _key: ConsoleKeyDep,
            rig: Annotated[str, Query(max_length=20)] = "",
            since: Annotated[str, Query(max_length=64)] = "",
            until: Annotated[str, Query(max_length=64)] = "",
            page_number: Annotated[int, Query(alias="page", ge=1, le=MAX_ID)] = 1) -> Response:
    """Every stored diagnosis, newest first, filtered by rig and time (blank: any), paginated.

    A filter that cannot be read (a time without its zone, ``since`` after ``until``) is
    named above the form, which keeps what was typed (422), instead of replacing the page.
    """
    rows, _ = rig_service.rig_choices(session)
    try:
        rig_id, start, end = _rig(rig), _time(since, "since"), _time(until, "until")
        if rig_id is not None:  # an unknown rig is a 404, as on the series and trends pages
            rig_service.get_rig(session, rig_id)  # (it showed an empty list: a console pass)
        found = history_page(session, rig_id=rig_id, since=start, until=end,
                             page=page_number)
    except InputError as exc:
        typed = {"rig": int(rig) if rig.strip().isdigit() else "", "since": since,
                 "until": until}
        return page(request, "history.html", status_code=422, error=filter_error(exc),
                    found=HistoryPage([], 0, 1, 1), rigs=rows, query=typed)
    query = {"rig": "" if rig_id is None else rig_id, "since": _stamp(start),
             "until": _stamp(end)}
    return page(request, "history.html", found=found, rigs=rows, query=query)


@router.get("/trends")
def trends(request: Request, session: SessionDep, rigs: RigsDep, _key: ConsoleKeyDep,
           rig: Annotated[int, Query(ge=1, le=MAX_ID)] = 1,
           since: Annotated[str, Query(max_length=64)] = "",
           until: Annotated[str, Query(max_length=64)] = "") -> Response:
    """Per component: estimates over time, Theil–Sen line and band, threshold, time left
    (a filter that cannot be read is named above the form, as on the history page)."""
    rows, _ = rig_service.rig_choices(session)
    try:
        start, end = _time(since, "since"), _time(until, "until")
        views = trend_views(session, rigs, rig, since=start, until=end)
    except InputError as exc:
        return page(request, "trends.html", status_code=422, error=filter_error(exc),
                    views=[], rigs=rows, rig_id=rig, query={"since": since, "until": until})
    return page(request, "trends.html", views=views, rigs=rows, rig_id=rig,
                query={"since": _stamp(start), "until": _stamp(end)})
