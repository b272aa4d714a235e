"""Diagnosis of measurement records: ``POST /diagnose``.

The route is ``async`` and thin: the body is validated on the event loop; the store is
read (key, rigs) in one thread-pool call; the diagnoses are computed by the application's
:class:`~app.services.diagnosis_pool.DiagnosisPool` (worker processes, so the event loop
never waits for a diagnosis's interpreter lock); the results are stored by the
application's :class:`~app.services.group_commit.GroupCommitter` (the rows of concurrent
requests in one transaction, each answered after that commit) and the answer is
serialised once by pydantic's compiled serialiser.  A server process takes at most
``diagnosis_queue`` diagnosis requests at once; one more is answered 503 with
``Retry-After`` at once rather than queued past its client's deadline.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from datetime import datetime
from functools import partial

from fastapi import APIRouter, Depends, Request, Response
from sqlalchemy.orm import Session

from app.api.deps import KeyHeaderDep, ReadAccess, SessionDep, SettingsDep, require_write_key
from app.db.base import utcnow
from app.limits import check_count
from app.schemas.common import ERROR_RESPONSES, error_doc
from app.schemas.diagnose import DiagnoseRequest, DiagnoseResponse
from app.services.diagnosis import (
    STORE_CONFLICT,
    GroupPlan,
    add_outcomes,
    outcome_of,
    plan_groups,
    response_json,
)
from app.services.diagnosis_pool import DiagnosisPool
from app.services.group_commit import GroupCommitter

__all__ = ["router"]


async def _admitted(request: Request) -> AsyncIterator[None]:
    """Count the request in (before anything reads the store), or answer 503 at once."""
    pool: DiagnosisPool = request.app.state.diagnosis_pool
    with pool.admit():
        yield


router = APIRouter(tags=["diagnosis"], dependencies=[Depends(_admitted), ReadAccess],
                   responses=ERROR_RESPONSES)


def _plan(request: Request, session: Session, body: DiagnoseRequest, key: str | None,
          now: datetime) -> list[GroupPlan]:
    """Check the key (scope ``write``) when storing, resolve the rigs and build the records;
    then close the request's session, so that no connection is held while the diagnoses are
    computed."""
    try:
        if body.store:
            require_write_key(request, session, key)
        return plan_groups(session, request.app.state.rigs, body, now)
    finally:
        session.close()


@router.post("/diagnose", summary="Diagnose one record or a batch, and store them",
             openapi_extra={"x-hydrodiag-scope-store": "write"},
             response_model=DiagnoseResponse, responses={503: error_doc(
                 "As many diagnoses queued as the service accepts "
                 "(HYDRODIAG_DIAGNOSIS_QUEUE); retry after Retry-After")})
async def diagnose(body: DiagnoseRequest, request: Request, session: SessionDep,
                   key: KeyHeaderDep, settings: SettingsDep) -> Response:
    """Rank the fault hypotheses for each record (or for all records jointly).

    Records and results are stored in the history unless ``store`` is false; storing needs
    a key of scope ``write``.  A request that fails in any record stores nothing; one with
    more records than ``HYDRODIAG_MAX_BATCH_RECORDS`` is a 422.  With ``compact`` the
    answer leaves out each hypothesis's predicted readings.
    """
    items = body.items()  # a malformed request is a 422 before it is a 401
    check_count(len(items), settings.max_batch_records, what="records", field="records",
                setting="max_batch_records")
    now = utcnow()
    pool: DiagnosisPool = request.app.state.diagnosis_pool
    plans = await pool.in_thread(partial(_plan, request, session, body, key, now))
    computed = await asyncio.gather(*(pool.compute(plan) for plan in plans))
    outcomes = [outcome_of(plan, result) for plan, result in zip(plans, computed, strict=True)]
    if body.store:  # answered once the group transaction holding its rows has committed
        writer: GroupCommitter = request.app.state.diagnosis_writer
        await writer.write(lambda s: add_outcomes(s, body, outcomes, now),
                           conflict=STORE_CONFLICT)
    return Response(response_json(body, outcomes), media_type="application/json")
