"""The stored history read back: ``/measurements`` and ``/diagnoses``.

A client that lost an answer (a timeout, a crash) checks here what was stored.
"""

from __future__ import annotations

import logging
from typing import Annotated

from fastapi import APIRouter, Path, Query, Response, status

from app.api.deps import AdminKeyDep, PageDep, ReadAccess, SessionDep
from app.api.rendered import rendered
from app.schemas.common import ERROR_RESPONSES, MAX_ID
from app.schemas.history import (
    BlamedComponent,
    StoredDiagnosisList,
    StoredDiagnosisPublic,
    StoredMeasurementList,
    StoredMeasurementPublic,
)
from app.schemas.times import SinceTime, UntilTime
from app.services import readback as service

__all__ = ["router"]

logger = logging.getLogger("hydrodiag.app")

router = APIRouter(tags=["history"], dependencies=[ReadAccess], responses=ERROR_RESPONSES)

RigFilter = Annotated[int | None, Query(ge=1, le=MAX_ID, description="Only this rig [-]",
                                        examples=[1])]
Since = Annotated[SinceTime | None, Query(
    description="Only records taken at or after this time, ISO 8601 with zone, or a date "
    "alone (the start of that day) [UTC]",
    examples=["2026-01-01T00:00:00Z"])]
Until = Annotated[UntilTime | None, Query(
    description="Only records taken at or before this time, ISO 8601 with zone, or a date "
    "alone (the end of that day) [UTC]",
    examples=["2026-12-31T23:59:59Z"])]
AfterId = Annotated[int | None, Query(
    ge=0, le=MAX_ID, description="A cursor: only items stored after the one with this id, "
    "in storing order (oldest stored first), without offset; pass each page's "
    "`next_after_id` to read on or to poll what is new (0: from the first) [-]",
    examples=[0])]


def _next(after_id: int | None, ids: list[int]) -> int | None:
    """The cursor after a page read with ``after_id`` (``None`` without one)."""
    return None if after_id is None else (ids[-1] if ids else after_id)


@router.get("/measurements", summary="List stored measurement records",
            response_model=StoredMeasurementList)
def list_measurements(session: SessionDep, page: PageDep, rig_id: RigFilter = None,
                      since: Since = None, until: Until = None, after_id: AfterId = None
                      ) -> Response:
    """Return a page of the records stored by ``/diagnose``, newest measurement first, or
    with ``after_id`` those stored after it, in storing order."""
    rows, total = service.list_measurements(session, limit=page.limit, offset=page.offset,
                                            rig_id=rig_id, since=since, until=until,
                                            after_id=after_id)
    return rendered(StoredMeasurementList(
        items=[service.public_measurement(r) for r in rows], total=total, limit=page.limit,
        offset=page.offset, next_after_id=_next(after_id, [r.id for r in rows])))


@router.get("/measurements/{measurement_id}", summary="Get a stored measurement record")
def get_measurement(
    measurement_id: Annotated[int, Path(ge=1, le=MAX_ID, description="Measurement "
                                        "identifier [-]", examples=[1])],
    session: SessionDep,
) -> StoredMeasurementPublic:
    """Return the record as posted, with the ids of its diagnoses."""
    return service.public_measurement(service.get_measurement(session, measurement_id))


@router.delete("/measurements/{measurement_id}", status_code=status.HTTP_204_NO_CONTENT,
               response_class=Response, summary="Delete a stored measurement record")
def delete_measurement(
    measurement_id: Annotated[int, Path(ge=1, le=MAX_ID, description="Measurement "
                                        "identifier [-]", examples=[1])],
    session: SessionDep, key: AdminKeyDep,
) -> None:
    """Delete the record and every diagnosis made from it (its own, and the joint ones it
    took part in, with the other records of such a visit that no other diagnosis keeps),
    with their estimates, so that trends forget it — a record entered wrongly; post the
    corrected record, or visit, after (a key of scope ``admin``).  The deletion is logged
    with the key and the ids."""
    diagnoses, records = service.delete_measurement(session, measurement_id)
    logger.info("measurement %d deleted: records %s, diagnoses %s, by key %s", measurement_id,
                records, diagnoses, key.id)


@router.get("/diagnoses", summary="List stored diagnoses", response_model=StoredDiagnosisList)
def list_diagnoses(
    session: SessionDep, page: PageDep, rig_id: RigFilter = None, since: Since = None,
    until: Until = None,
    component: Annotated[BlamedComponent | None, Query(
        description="Only diagnoses whose top hypothesis blames this component: a single "
        "component also finds the pairs that blame it ('valve' finds 'valve+pump'); a pair, "
        "'healthy' or 'unexplained' only itself [-]",
        examples=["valve"])] = None,
    after_id: AfterId = None,
    compact: Annotated[bool, Query(
        description="Each `result` without the hypotheses' predicted readings (a page about "
        "a fifth smaller: 500 items 6.5 → 5.2 MB; GET /diagnoses/{id} "
        "keeps them) [-]", examples=[False])] = False,
    superseded: Annotated[bool, Query(
        description="Also the diagnoses a re-diagnosis against a later rig version replaced "
        "(each with `superseded_by`); by default only the current ones [-]",
        examples=[False])] = False,
) -> Response:
    """Return a page of stored diagnoses, newest record first, or with ``after_id`` those
    stored after it, in storing order."""
    rows, total = service.list_diagnoses(session, limit=page.limit, offset=page.offset,
                                         rig_id=rig_id, since=since, until=until,
                                         component=component, after_id=after_id,
                                         superseded=superseded)
    return rendered(StoredDiagnosisList(
        items=[service.public_diagnosis(r, compact) for r in rows], total=total, limit=page.limit,
        offset=page.offset, next_after_id=_next(after_id, [r.id for r in rows])))


@router.get("/diagnoses/{diagnosis_id}", summary="Get a stored diagnosis")
def get_diagnosis(
    diagnosis_id: Annotated[int, Path(ge=1, le=MAX_ID, description="Diagnosis identifier [-]",
                                      examples=[1])],
    session: SessionDep,
) -> StoredDiagnosisPublic:
    """Return the diagnosis with its estimates and full result."""
    return service.public_diagnosis(service.get_diagnosis(session, diagnosis_id))
