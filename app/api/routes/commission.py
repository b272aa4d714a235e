"""Commissioning a rig from healthy records: ``POST /rigs/{rig_id}/commission``."""

from __future__ import annotations

from fastapi import APIRouter, Response, status

from app.api.deps import ReadAccess, RigsDep, SessionDep, WriteKeyDep
from app.api.routes.rigs import RigId
from app.schemas.commission import CommissionRequest, CommissionResponse
from app.schemas.common import ERROR_RESPONSES
from app.services.commissioning import commission_rig

__all__ = ["router"]

router = APIRouter(tags=["rigs"], dependencies=[ReadAccess], responses=ERROR_RESPONSES)


@router.post("/rigs/{rig_id}/commission", status_code=status.HTTP_201_CREATED,
             summary="Fit a rig's uncertain parameters to healthy records; store a version",
             responses={200: {"model": CommissionResponse,
                              "description": "The records confirm the document: every "
                              "pinned-down interval holds its value; nothing stored"}})
def commission(rig_id: RigId, body: CommissionRequest, session: SessionDep, rigs: RigsDep,
               _key: WriteKeyDep, response: Response) -> CommissionResponse:
    """Fit seal and land lengths, valve coefficient, friction and pump leakage to records
    of the healthy rig, with 95 % intervals and what the records could not pin down; the
    pinned-down values are stored as the rig's next version (201), unless every interval
    holds the document's value: then nothing is stored (200, ``stored: false``)."""
    answer = commission_rig(session, rigs, rig_id, body)
    if not answer.stored:
        response.status_code = status.HTTP_200_OK
    return answer
