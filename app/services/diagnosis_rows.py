"""Store the rows of diagnoses with SQLAlchemy Core: no ORM objects, JSON serialised already.

The group-commit writer (:mod:`app.services.group_commit`) runs in the server process; the
ORM flush of a stored diagnosis (a measurement, a diagnosis and its estimates as mapped
objects, their JSON documents serialised there) was a quarter of that process's CPU per
request (profile of issue 9).  :func:`insert_rows` inserts the same rows with Core
``INSERT`` statements, the JSON documents as the text the diagnosis process serialised
(:class:`~app.services.diagnosis_task.StoredRows`): what is stored is what the ORM stored,
read back through the same models.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from functools import cache
from typing import Any

from sqlalchemy import JSON, ColumnElement, Insert, Table, Text, bindparam, cast, insert, type_coerce
from sqlalchemy.dialects.postgresql import JSONB
from sqlalchemy.orm import Session

from app.db.base import utcnow
from app.db.engine import loads_json
from app.db.models import Diagnosis, DiagnosisEstimate, DiagnosisRecord, Measurement
from app.services.diagnosis_answer import StoredRows
from app.services.history import stored_series_twin, stored_twin, timeless
from sim.errors import ConflictError

__all__ = ["insert_rows"]

_MEASUREMENTS: Table = Measurement.__table__  # type: ignore[assignment]
_DIAGNOSES: Table = Diagnosis.__table__  # type: ignore[assignment]
_ESTIMATES: Table = DiagnosisEstimate.__table__  # type: ignore[assignment]
_RECORDS: Table = DiagnosisRecord.__table__  # type: ignore[assignment]


def _json(name: str, dialect: str) -> ColumnElement[Any]:
    """The bound parameter ``name`` (a JSON document as text) as the value of a JSON
    column."""
    value = type_coerce(bindparam(name), Text)
    if dialect == "sqlite":  # SQLite keeps JSON as its text
        return value
    return cast(value, JSONB if dialect == "postgresql" else JSON)


@cache
def _statements(dialect: str) -> tuple[Insert, Insert, Insert, Insert]:
    """The four inserts for ``dialect``, built once: a statement built per row cost its
    cache key's generation each time (issue 9)."""
    measurement = insert(_MEASUREMENTS).values(
        rig_id=bindparam("rig_id"), measured_at=bindparam("measured_at"),
        record=_json("record", dialect), created_at=bindparam("created_at"))
    diagnosis = insert(_DIAGNOSES).values(
        measurement_id=bindparam("measurement_id"), rig_version_id=bindparam("rig_version_id"),
        component=bindparam("component"), probability=bindparam("probability"),
        result=_json("result", dialect), created_at=bindparam("created_at"))
    return measurement, diagnosis, insert(_ESTIMATES), insert(_RECORDS)


def insert_rows(session: Session, rows: Sequence[StoredRows]) -> list[tuple[int, list[int]]]:
    """Insert the rows of each diagnosis (no commit).

    Parameters
    ----------
    session
        Session of the store, in the transaction that will hold the rows.
    rows
        One per diagnosis.

    Returns
    -------
    list of (diagnosis id, measurement ids)
        Per diagnosis, its id and its records' ids in request order.

    Raises
    ------
    IntegrityError
        A constraint refused a row (a rig or version deleted meanwhile).
    ConflictError
        A record stored already with a diagnosis against the same rig version
        (:func:`~app.services.history.stored_twin`, and a record read from a stored
        series: :func:`~app.services.history.stored_series_twin`).
    """
    connection = session.connection()  # Core statements on the session's transaction
    add_measurement, add_diagnosis, add_estimates, add_records = _statements(
        connection.dialect.name)
    now = utcnow()
    ids: list[tuple[int, list[int]]] = []
    _request_twins(rows)
    for item in rows:
        if item.stated:
            measured_at, record = item.measurements[item.latest]
            try:
                stored_twin(connection, item.rig_id, item.rig_version_id, measured_at, record)
            except ConflictError as exc:  # which of a batch's records (a fleet integrator's
                if item.path == "record":  # pass: a bare measured_at in a 100-record batch)
                    raise
                raise ConflictError(f"{item.path}: {exc.message}",
                                    field=f"{item.path}.measured_at") from None
        stored_series_twin(connection, item.rig_id, item.rig_version_id,
                           [record for _, record in item.measurements])
        measurement_ids = [
            int(connection.execute(add_measurement, {
                "rig_id": item.rig_id, "measured_at": measured_at,
                "record": record.decode(), "created_at": now,
            }).inserted_primary_key[0])  # type: ignore[index]
            for measured_at, record in item.measurements]
        diagnosis_id = int(connection.execute(add_diagnosis, {
            "measurement_id": measurement_ids[item.latest],
            "rig_version_id": item.rig_version_id, "component": item.component,
            "probability": item.probability, "result": item.result.decode(),
            "created_at": now,
        }).inserted_primary_key[0])  # type: ignore[index]
        connection.execute(add_records, [  # every record the diagnosis was made from
            {"diagnosis_id": diagnosis_id, "measurement_id": m} for m in measurement_ids])
        if item.estimates:
            connection.execute(add_estimates, [
                {"diagnosis_id": diagnosis_id, "component": component,
                 "probability": probability, "clearance_m": clearance,
                 "slip_coefficient": slip, "low": low, "high": high}
                for component, probability, clearance, slip, low, high in item.estimates])
        ids.append((diagnosis_id, measurement_ids))
    return ids


def _request_twins(rows: Sequence[StoredRows]) -> None:
    """Refuse a request that holds the same record twice (same rig, version, instant and
    readings): the second was refused as the twin of the first's diagnosis, an id of the
    transaction that was then rolled back and later given to another diagnosis (a fleet
    integrator's pass)."""
    if len(rows) < 2:  # one diagnosis has no twin in its request: no decoding on the hot path
        return
    seen: dict[tuple[Any, ...], str] = {}
    for item in rows:
        if not item.stated:
            continue
        measured_at, record = item.measurements[item.latest]
        key = (item.rig_id, item.rig_version_id, measured_at,
               json.dumps(timeless(loads_json(record)), sort_keys=True))
        if key in seen:
            raise ConflictError(f"{item.path} repeats {seen[key]} (the same rig, time and "
                                "readings): send it once", field=item.path)
        seen[key] = item.path
