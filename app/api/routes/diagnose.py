"""Diagnosis of measurement records: ``POST /diagnose``.

The route is ``async`` and a thin pipe (issue 9): the body is validated on the event loop
(FastAPI: a malformed request is a 422 naming the field before anything else), the key is
checked on the event loop (:func:`~app.api.deps.require_key_on_loop`: scope ``write`` to
store), and the request's validated form (:mod:`app.services.diagnosis_form`: plain data,
not validated again) goes to a diagnosis process of the application's
:class:`~app.services.diagnosis_pool.DiagnosisPool`, which resolves the rigs, diagnoses,
and encodes the answer and the rows from one encoding of each result
(:mod:`app.services.diagnosis_task`).  The rows are stored by the application's
:class:`~app.services.group_commit.GroupCommitter`
(the rows of concurrent requests in one transaction, SQLAlchemy Core inserts,
:mod:`app.services.diagnosis_rows`), and the answer, its stored ids spliced in, is sent
once that transaction has committed.  A server process refuses a request (503 with
``Retry-After``, before any work) when ``diagnosis_queue`` requests are in or the expected
wait for a diagnosis process is over ``diagnosis_wait_ms``.
"""

from __future__ import annotations

import time
from collections.abc import AsyncIterator

from fastapi import APIRouter, Depends, Request, Response
from sqlalchemy.orm import Session

from app.api.deps import KeyHeaderDep, SettingsDep, read_access_on_loop, require_key_on_loop
from app.db.base import utcnow
from app.limits import check_count
from app.metrics import STARTED
from app.schemas.common import ERROR_RESPONSES, error_doc
from app.schemas.diagnose import DiagnoseRequest, DiagnoseResponse
from app.security import Scope
from app.services.diagnosis import STORE_CONFLICT
from app.services.diagnosis_answer import DiagnoseAnswer
from app.services.diagnosis_form import request_form
from app.services.diagnosis_pool import DiagnosisPool
from app.services.diagnosis_rows import insert_rows
from app.services.diagnosis_task import DiagnoseTask
from app.services.group_commit import GroupCommitter
from app.services.idempotent_work import CURRENT, keep_answer

__all__ = ["router"]


async def _admitted(request: Request) -> AsyncIterator[None]:
    """Count the request in (before its body is read), or answer 503 at once."""
    pool: DiagnosisPool = request.app.state.diagnosis_pool
    with pool.admit():
        yield


router = APIRouter(tags=["diagnosis"],
                   dependencies=[Depends(_admitted), Depends(read_access_on_loop)],
                   responses=ERROR_RESPONSES)


class _Rows:
    """A repeatable write of a request's rows (the group committer may run it twice); with
    ``keyed`` (the request's ``Idempotency-Key`` row), the answer is kept in the same
    transaction, so a retry after the process died between commit and answer is replayed
    (:mod:`app.services.idempotent_work`)."""

    def __init__(self, answer: DiagnoseAnswer, keyed: int | None) -> None:
        self.answer, self.keyed = answer, keyed
        self.ids: list[tuple[int, list[int]]] = []
        self.body = b""

    def __call__(self, session: Session) -> None:
        self.ids = insert_rows(session, self.answer.rows)
        self.body = self.answer.body(self.ids)
        if self.keyed is not None:
            keep_answer(session, self.keyed, 200, self.body)


@router.post("/diagnose", summary="Diagnose one record or a batch, and store them",
             openapi_extra={"x-hydrodiag-scope-store": "write"},
             response_model=DiagnoseResponse, responses={503: error_doc(
                 "As many diagnoses queued as the service accepts "
                 "(HYDRODIAG_DIAGNOSIS_QUEUE), or a longer expected wait than the service "
                 "accepts (HYDRODIAG_DIAGNOSIS_WAIT_MS); retry after Retry-After")})
async def diagnose(body: DiagnoseRequest, request: Request, key: KeyHeaderDep,
                   settings: SettingsDep) -> Response:
    """Rank the fault hypotheses for each record (or for all records jointly).

    Records and results are stored in the history unless ``store`` is false; storing needs
    a key of scope ``write``.  A request that fails in any record stores nothing; one with
    more records than ``HYDRODIAG_MAX_BATCH_RECORDS`` is a 422.  With ``compact`` the
    answer leaves out each hypothesis's predicted readings.
    """
    form = request_form(body)  # a malformed request is a 422 before it is a 401
    check_count(len(form.records), settings.max_batch_records, what="records", field="records",
                setting="max_batch_records")
    if body.store:
        await require_key_on_loop(request, key, Scope.WRITE)
    pool: DiagnosisPool = request.app.state.diagnosis_pool
    answer = await pool.diagnose(DiagnoseTask(form, utcnow()))
    if not body.store:
        return Response(answer.body(), media_type="application/json")
    # answered once the group transaction holding its rows has committed
    keyed = CURRENT.get()
    write = _Rows(answer, None if keyed is None else keyed.row_id)
    writer: GroupCommitter = request.app.state.diagnosis_writer
    handed = time.perf_counter()
    await writer.write(write, conflict=STORE_CONFLICT)
    done = time.perf_counter()
    stages = request.app.state.metrics.diagnosis_stage
    stages.labels("commit").observe(done - handed)
    stages.labels("request").observe(done - getattr(request.state, STARTED, done))
    if keyed is not None:
        keyed.kept = True
    return Response(write.body, media_type="application/json")
