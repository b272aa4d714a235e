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

from collections.abc import Sequence
from typing import Any

from sqlalchemy import JSON, ColumnElement, Table, Text, cast, insert, type_coerce
from sqlalchemy.dialects.postgresql import JSONB
from sqlalchemy.orm import Session

from app.db.base import utcnow
from app.db.models import Diagnosis, DiagnosisEstimate, Measurement
from app.services.diagnosis_answer import StoredRows

__all__ = ["insert_rows"]

_MEASUREMENTS: Table = Measurement.__table__  # type: ignore[assignment]
_DIAGNOSES: Table = Diagnosis.__table__  # type: ignore[assignment]
_ESTIMATES: Table = DiagnosisEstimate.__table__  # type: ignore[assignment]


def _json(encoded: bytes, dialect: str) -> ColumnElement[Any]:
    """``encoded`` (a JSON document, UTF-8) as the value of a JSON column."""
    value = type_coerce(encoded.decode(), Text)
    if dialect == "sqlite":  # SQLite keeps JSON as its text
        return value
    return cast(value, JSONB if dialect == "postgresql" else JSON)


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
    """
    connection = session.connection()  # Core statements on the session's transaction
    dialect = connection.dialect.name
    now = utcnow()
    ids: list[tuple[int, list[int]]] = []
    for item in rows:
        measurement_ids = [
            int(connection.execute(insert(_MEASUREMENTS).values(
                rig_id=item.rig_id, measured_at=measured_at,
                record=_json(record, dialect), created_at=now,
            )).inserted_primary_key[0])  # type: ignore[index]
            for measured_at, record in item.measurements]
        diagnosis_id = int(connection.execute(insert(_DIAGNOSES).values(
            measurement_id=measurement_ids[item.latest], rig_version_id=item.rig_version_id,
            component=item.component, probability=item.probability,
            result=_json(item.result, dialect), created_at=now,
        )).inserted_primary_key[0])  # type: ignore[index]
        if item.estimates:
            connection.execute(insert(_ESTIMATES), [
                {"diagnosis_id": diagnosis_id, "component": component,
                 "probability": probability, "clearance_m": clearance,
                 "slip_coefficient": slip}
                for component, probability, clearance, slip in item.estimates])
        ids.append((diagnosis_id, measurement_ids))
    return ids
