"""Reading the stored history back: measurements and diagnoses, filtered and paged."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime
from typing import Any

from sqlalchemy import Select, func, or_, select
from sqlalchemy.orm import Session, contains_eager, joinedload, selectinload

from app.db.models import Diagnosis, DiagnosisEstimate, Measurement, RigVersion
from app.schemas.history import (
    StoredDiagnosisPublic,
    StoredEstimatePublic,
    StoredMeasurementPublic,
)
from app.services.common import commit, current_diagnoses, get_or_raise
from app.services.diagnosis_response import compact_result
from sim.errors import InputError, NotFoundError

__all__ = ["delete_measurement", "get_diagnosis", "get_measurement", "list_diagnoses",
           "list_measurements", "public_diagnosis", "public_measurement"]

#: The fields of an answer's estimate that a stored result keeps beside the trend columns.
_ANSWER_FIELDS = ("quantity", "unit", "value", "low", "high", "source")


def _window(since: datetime | None, until: datetime | None) -> None:
    if since is not None and until is not None and until < since:
        raise InputError("`until` is before `since`", field="until")


def _page(session: Session, whole: Select[Any], conditions: Sequence[Any], key: Any, *,
          limit: int, offset: int, order: Sequence[Any]) -> tuple[list[Any], int]:
    """One page of ``whole``'s rows that meet ``conditions``, in ``order``, and their total.
    The page's ids (``key``) are found and counted on the ids alone, and then only the
    page's rows are read, by id: ordering the whole rows sorted every stored record and
    result with them (a history of 100,000 diagnoses, ~14 kB each: 1.1 s for the first
    page; a store-scale pass, ``make history-bench``)."""
    ids = whole.with_only_columns(key).where(*conditions)
    total = session.scalar(select(func.count()).select_from(ids.subquery()))
    page = session.scalars(ids.order_by(*order).limit(limit).offset(offset)).all()
    if not page:
        return [], int(total or 0)
    rows = session.scalars(whole.where(key.in_(page)).order_by(*order)).all()
    return list(rows), int(total or 0)


def _cursor(after_id: int | None, offset: int) -> None:
    if after_id is not None and offset:
        raise InputError("after_id reads on from an id (in storing order): it goes without "
                         "offset", field="offset")


def list_measurements(session: Session, *, limit: int, offset: int, rig_id: int | None = None,
                      since: datetime | None = None, until: datetime | None = None,
                      after_id: int | None = None) -> tuple[list[Measurement], int]:
    """Return a page of stored records, newest measurement first (with ``after_id``: those
    stored after record ``after_id``, in storing order), and their total."""
    _window(since, until)
    _cursor(after_id, offset)
    whole = select(Measurement).options(
        selectinload(Measurement.diagnosed_in).load_only(Diagnosis.id))
    conditions: list[Any] = []
    if rig_id is not None:
        conditions.append(Measurement.rig_id == rig_id)
    if since is not None:
        conditions.append(Measurement.measured_at >= since)
    if until is not None:
        conditions.append(Measurement.measured_at <= until)
    if after_id is not None:
        return _page(session, whole, [*conditions, Measurement.id > after_id], Measurement.id,
                     limit=limit, offset=0, order=(Measurement.id.asc(),))
    return _page(session, whole, conditions, Measurement.id, limit=limit, offset=offset,
                 order=(Measurement.measured_at.desc(), Measurement.id.desc()))


def get_measurement(session: Session, measurement_id: int) -> Measurement:
    """Return stored record ``measurement_id`` (404 when unknown)."""
    measurement: Measurement = get_or_raise(session, Measurement, measurement_id,
                                            what="measurement", field="measurement_id")
    return measurement


def delete_measurement(session: Session, measurement_id: int) -> tuple[list[int], list[int]]:
    """Delete stored record ``measurement_id``, every diagnosis made from it — its own and
    the joint ones it took part in — with their estimates, and the other records of those
    joint visits that no other diagnosis keeps (a visit is posted again whole, and a record
    left without a diagnosis was stored twice beside the re-post: a check of the planner's
    fix); return the deleted diagnoses' and records' ids.  A record entered wrongly could
    not be removed: a corrected one was stored beside it and both moved the trend (a
    maintenance planner's pass)."""
    measurement = get_measurement(session, measurement_id)
    diagnoses = {d.id: d for d in (*measurement.diagnosed_in, *measurement.diagnoses)}
    records = {measurement.id: measurement}
    for diagnosis in diagnoses.values():
        for other in diagnosis.records:
            if all(d.id in diagnoses for d in (*other.diagnosed_in, *other.diagnoses)):
                records[other.id] = other
    for diagnosis in diagnoses.values():
        session.delete(diagnosis)
    session.flush()
    for record in records.values():
        session.expire(record, ["diagnoses", "diagnosed_in"])   # emptied by the flush
        session.delete(record)
    commit(session, conflict=f"measurement {measurement_id} could not be deleted",
           field="measurement_id")
    return sorted(diagnoses), sorted(records)


def list_diagnoses(session: Session, *, limit: int, offset: int, rig_id: int | None = None,
                   since: datetime | None = None, until: datetime | None = None,
                   component: str | None = None, after_id: int | None = None,
                   superseded: bool = False) -> tuple[list[Diagnosis], int]:
    """Return a page of stored diagnoses, newest record first (with ``after_id``: those
    stored after diagnosis ``after_id``, in storing order), and their total; only the
    current ones unless ``superseded`` (those a re-diagnosis replaced too)."""
    _window(since, until)
    _cursor(after_id, offset)
    # the record and the rig version from the page's own statement: read by statements of
    # their own, a delete between them left ``measurement`` None and the page a 500 (179
    # of them in 15 rounds of deletes: a verification pass)
    whole = (select(Diagnosis).join(Diagnosis.measurement)
             .options(selectinload(Diagnosis.estimates),
                      contains_eager(Diagnosis.measurement),
                      selectinload(Diagnosis.records).load_only(Measurement.id),
                      joinedload(Diagnosis.rig_version).load_only(RigVersion.version)))
    conditions: list[Any] = [] if superseded else [current_diagnoses()]
    if rig_id is not None:
        conditions.append(Measurement.rig_id == rig_id)
    if since is not None:
        conditions.append(Measurement.measured_at >= since)
    if until is not None:
        conditions.append(Measurement.measured_at <= until)
    if component is not None:  # a component alone also finds the pairs that blame it
        blamed = Diagnosis.component == component
        if "+" not in component and component not in ("healthy", "unexplained"):
            blamed = or_(blamed, Diagnosis.component.like(f"{component}+%"),
                         Diagnosis.component.like(f"%+{component}"))
        conditions.append(blamed)
    if after_id is not None:
        return _page(session, whole, [*conditions, Diagnosis.id > after_id], Diagnosis.id,
                     limit=limit, offset=0, order=(Diagnosis.id.asc(),))
    return _page(session, whole, conditions, Diagnosis.id, limit=limit, offset=offset,
                 order=(Measurement.measured_at.desc(), Diagnosis.id.desc()))


def get_diagnosis(session: Session, diagnosis_id: int) -> Diagnosis:
    """Return stored diagnosis ``diagnosis_id`` with what its read-back shows (404 when
    unknown, or deleted with its record while it was read: its record and rig version came
    back None from their own statements, a 500 on ``row.measurement.rig_id``; an SRE
    pass)."""
    diagnosis = session.execute(
        select(Diagnosis).where(Diagnosis.id == diagnosis_id).options(
            joinedload(Diagnosis.measurement), joinedload(Diagnosis.rig_version),
            selectinload(Diagnosis.records), selectinload(Diagnosis.estimates))
    ).unique().scalar_one_or_none()
    if diagnosis is None or diagnosis.measurement is None or diagnosis.rig_version is None:
        raise NotFoundError(f"no diagnosis with id {diagnosis_id}", field="diagnosis_id")
    return diagnosis


def public_measurement(row: Measurement) -> StoredMeasurementPublic:
    """A stored record as ``GET /measurements`` reads it back."""
    return StoredMeasurementPublic(
        id=row.id, rig_id=row.rig_id, measured_at=row.measured_at, record=row.record,
        diagnosis_ids=sorted(d.id for d in row.diagnosed_in), created_at=row.created_at)


def _estimate(row: DiagnosisEstimate, result: dict[str, Any]) -> StoredEstimatePublic:
    """A stored estimate with the answer's fields kept in the stored result (its interval,
    unit and source), so that both read backs have one shape (a fleet pass)."""
    kept = (result.get("estimates") or {}).get(row.component) or {}
    answer = {name: kept.get(name) for name in _ANSWER_FIELDS}
    return StoredEstimatePublic(
        component=row.component, probability=row.probability, clearance_m=row.clearance_m,
        slip_coefficient=row.slip_coefficient, **answer)


def public_diagnosis(row: Diagnosis, compact: bool = False) -> StoredDiagnosisPublic:
    """A stored diagnosis as ``GET /diagnoses`` reads it back (HTTP and ``hydrodiag
    history``); ``compact`` drops each hypothesis's predicted readings."""
    result = compact_result(row.result) if compact else row.result
    return StoredDiagnosisPublic(
        id=row.id, measurement_id=row.measurement_id,
        measurement_ids=sorted(m.id for m in row.records), rig_id=row.measurement.rig_id,
        rig_version=row.rig_version.version, measured_at=row.measurement.measured_at,
        top=row.result.get("top"), explained=row.result.get("explained"),
        component=row.component, probability=row.probability,
        estimates=[_estimate(e, row.result) for e in row.estimates],
        result=result, created_at=row.created_at, superseded_by=row.superseded_by,
        supersedes=row.result.get("rediagnosis_of"))
