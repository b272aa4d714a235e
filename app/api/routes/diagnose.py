"""Diagnosis of measurement records: ``POST /diagnose``."""

from __future__ import annotations

from fastapi import APIRouter, Request

from app.api.deps import (
    KeyHeaderDep,
    ReadAccess,
    RigsDep,
    SessionDep,
    SettingsDep,
    require_write_key,
)
from app.limits import check_count
from app.schemas.common import ERROR_RESPONSES
from app.schemas.diagnose import DiagnoseRequest, DiagnoseResponse
from app.services.diagnosis import diagnose_request, response_of

__all__ = ["router"]

router = APIRouter(tags=["diagnosis"], dependencies=[ReadAccess], responses=ERROR_RESPONSES)


@router.post("/diagnose", summary="Diagnose one record or a batch, and store them",
             openapi_extra={"x-hydrodiag-scope-store": "write"})
def diagnose(body: DiagnoseRequest, request: Request, session: SessionDep, rigs: RigsDep,
             key: KeyHeaderDep, settings: SettingsDep) -> DiagnoseResponse:
    """Rank the fault hypotheses for each record (or for all records jointly).

    Records and results are stored in the history unless ``store`` is false; storing needs
    a key of scope ``write``.  A request that fails in any record stores nothing; one with
    more records than ``HYDRODIAG_MAX_BATCH_RECORDS`` is a 422.
    """
    items = body.items()  # a malformed request is a 422 before it is a 401
    check_count(len(items), settings.max_batch_records, what="records", field="records",
                setting="max_batch_records")
    if body.store:
        require_write_key(request, session, key)
    return response_of(body, diagnose_request(session, rigs, body))
