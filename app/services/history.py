"""Measurement and diagnosis history: the source of trends.

``/diagnose`` stores each measurement with its diagnosis in one transaction through
:func:`record_diagnosis`; ``/rigs/{id}/trends`` reads a component's series through
:func:`component_history`.  Each diagnosis keeps the rig version it was made with.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from functools import cache
from typing import Any

from sqlalchemy import Connection, Select, bindparam, select
from sqlalchemy.orm import Session

from app.db.engine import loads_json
from app.db.models import (
    Diagnosis,
    DiagnosisEstimate,
    DiagnosisRecord,
    Measurement,
    RigVersion,
)
from app.schemas.times import iso_utc
from app.services.common import commit, current_diagnoses
from app.services.rigs import get_rig, get_version
from sim.errors import ConflictError, InputError

__all__ = ["ComponentEstimate", "HistoryPoint", "add_diagnosis", "add_measurement",
           "component_history", "estimate_row", "record_diagnosis", "stated_bound",
           "stored_series_twin", "stored_twin", "timeless"]


@dataclass(frozen=True, slots=True)
class ComponentEstimate:
    """What a diagnosis estimated for one suspect component.

    Attributes
    ----------
    component
        Component name in the rig document (``"cylinder"``, ``"valve"``, ``"pump"``).
    probability
        Probability that this component is the faulty one [1], if ranked.
    clearance_m
        Equivalent internal clearance [m] (cylinder cc, valve cv).
    slip_coefficient
        Pump slip coefficient Cs [1] (paper 000, eq. 6).
    low, high
        The 95 % interval of the estimate [m, or 1 for Cs]; ``None``: read from the
        result's ``estimates`` when it has them.
    """

    component: str
    probability: float | None = None
    clearance_m: float | None = None
    slip_coefficient: float | None = None
    low: float | None = None
    high: float | None = None


@dataclass(slots=True)  # not frozen: a frozen one costs 5× to build, per row of a history
class HistoryPoint:
    """One point of a component's series: when, with which rig version, what estimate."""

    diagnosis_id: int
    measured_at: datetime
    rig_version: int
    probability: float | None
    clearance_m: float | None
    slip_coefficient: float | None
    #: what the diagnosis named (``"valve"``, ``"healthy"``, ``"unexplained"``)
    verdict: str | None = None
    #: the 95 % interval the diagnosis stated [unit of the estimate]
    low: float | None = None
    high: float | None = None


def stated_bound(result: Mapping[str, Any], component: str, bound: str) -> float | None:
    """``result["estimates"][component][bound]`` when it is a number, else ``None``."""
    estimates = result.get("estimates")
    entry = estimates.get(component) if isinstance(estimates, Mapping) else None
    value = entry.get(bound) if isinstance(entry, Mapping) else None
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


@cache
def _twins() -> Select[tuple[int, int, Any]]:
    """The diagnoses of the records of one rig at one time, built once (a statement built
    per call cost ~0.3 ms of its stored diagnosis's commit).  The version is compared in
    Python: with it in the query SQLite searched every diagnosis of the version (16 ms at
    12,600) instead of the records' (rig, time) index."""
    return (select(Diagnosis.id, Diagnosis.rig_version_id, Measurement.record)
            .select_from(Measurement)
            .join(Diagnosis, Diagnosis.measurement_id == Measurement.id)
            .where(Measurement.rig_id == bindparam("rig_id"),
                   Measurement.measured_at > bindparam("earliest"),
                   Measurement.measured_at < bindparam("latest")))


#: two stamps of one record are less than this apart [s]: a logger's re-export cut the
#: fractional seconds (15:45:28.070615 → 15:45:28) and the same readings were stored as a
#: second visit (a reliability engineer's pass)
SAME_RECORD_S = 1.0


def stored_twin(connection: Connection, rig_id: int, rig_version_id: int,
                measured_at: datetime, record: Mapping[str, Any] | bytes) -> None:
    """Refuse a diagnosis of a record that is stored already with a diagnosis against the
    same rig version: same rig, ``measured_at`` less than :data:`SAME_RECORD_S` apart, the same
    document (``record`` as the
    history keeps it, or its JSON).  A double submit without an ``Idempotency-Key``
    stored it twice and the trend fitted both points (an engineer's pass); the same
    record against another version (after commissioning) is a new diagnosis.

    Raises
    ------
    ConflictError
        Naming the stored diagnosis (``field`` ``measured_at``).
    """
    within = timedelta(seconds=SAME_RECORD_S)
    rows = [(i, stored) for i, version, stored in connection.execute(
        _twins(), {"rig_id": rig_id, "earliest": measured_at - within,
                   "latest": measured_at + within})
        if version == rig_version_id]
    if not rows:
        return
    document = timeless(loads_json(record) if isinstance(record, bytes) else record)
    for diagnosis_id, stored in rows:
        if timeless(stored) == document:
            raise ConflictError(
                f"this record (rig {rig_id}, measured {iso_utc(measured_at)}) is stored "
                f"already, diagnosed against the same rig version as diagnosis "
                f"{diagnosis_id}: send it with store false to diagnose it again, or with its "
                "own measured_at", field="measured_at")


def timeless(document: Any) -> Any:
    """A stored record's document without its ``measured_at``: the query matched the
    instant already, and the same instant written with another offset (``08:00+02:00`` for
    ``06:00Z``, a gateway's local time) stored the record twice (a fleet integrator's
    pass)."""
    if isinstance(document, Mapping):
        return {k: v for k, v in document.items() if k != "measured_at"}
    return document


@cache
def _series_diagnoses() -> Select[int, int]:
    """The diagnoses of a rig made from a record read from one stored series (the record's
    ``series_id``, which ``GET /series/{id}/record`` writes)."""
    return (select(Diagnosis.id, Diagnosis.rig_version_id)
            .select_from(Measurement)
            .join(DiagnosisRecord, DiagnosisRecord.measurement_id == Measurement.id)
            .join(Diagnosis, Diagnosis.id == DiagnosisRecord.diagnosis_id)
            .where(Measurement.rig_id == bindparam("rig_id"),
                   Measurement.record["series_id"].as_integer() == bindparam("series_id")))


def stored_series_twin(connection: Connection, rig_id: int, rig_version_id: int,
                       records: Sequence[Mapping[str, Any] | bytes]) -> None:
    """Refuse a diagnosis of a record read from a stored series (its ``series_id``) that a
    stored diagnosis against the same rig version was made from already, whatever its
    ``measured_at``: a series holds one measured cycle.  A series imported without its
    start gives records without a time, each stored at the time of its request, so
    :func:`stored_twin` never saw the repeat: following the README's walk-through stored
    one cycle four times and the trend counted each (a new engineer's pass).  Against a
    newer version (after commissioning) it is a new diagnosis.

    Raises
    ------
    ConflictError
        Naming the stored diagnosis (``field`` ``series_id``).
    """
    for record in records:
        if isinstance(record, bytes):
            if b'"series_id"' not in record:
                continue
            record = loads_json(record)
        series_id = record.get("series_id")
        if not isinstance(series_id, int):
            continue
        for diagnosis_id, version in connection.execute(
                _series_diagnoses(), {"rig_id": rig_id, "series_id": series_id}):
            if version == rig_version_id:
                raise ConflictError(
                    f"the cycle of series {series_id} is stored already, diagnosed against "
                    f"the same rig version as diagnosis {diagnosis_id}: send it with store "
                    "false to diagnose it again (GET /diagnoses/{id} reads the stored one)",
                    field="series_id")


def add_measurement(
    session: Session, *, rig_id: int, measured_at: datetime, record: Mapping[str, Any]
) -> Measurement:
    """Add a measurement without a diagnosis of its own (not committed).

    A joint diagnosis of several records attaches its result to one of them; the others
    are stored with this, in the same transaction.
    """
    if measured_at.tzinfo is None:
        raise InputError("give the time with its zone (ISO 8601, e.g. ...Z)",
                         field="measured_at")
    measurement = Measurement(rig_id=rig_id, measured_at=measured_at, record=dict(record))
    session.add(measurement)
    return measurement


def add_diagnosis(
    session: Session,
    *,
    rig_id: int,
    measured_at: datetime,
    record: Mapping[str, Any],
    result: Mapping[str, Any],
    component: str | None,
    probability: float | None,
    estimates: Sequence[ComponentEstimate] = (),
    rig_version: int | None = None,
    rig_version_id: int | None = None,
    stated: bool = True,
) -> Diagnosis:
    """Add a measurement and its diagnosis to the session without committing.

    Parameters are those of :func:`record_diagnosis`; the caller commits (several
    diagnoses of one request go in one transaction, so that a failure stores none).
    ``rig_version_id``, the row id of the rig version, spares the look-ups of a caller
    that has just resolved it (``rig_version`` is then ignored).  ``stated``: the record
    stated its ``measured_at``, so a stored twin is refused (:func:`stored_twin`).
    """
    if rig_version_id is None:
        rig = get_rig(session, rig_id, field="rig_id")
        version: RigVersion = get_version(session, rig_id, rig_version or rig.latest_version)
        rig_version_id = version.id
    names = [e.component for e in estimates]
    if len(set(names)) != len(names):
        raise InputError("one estimate per component", field="estimates")
    if stated and measured_at.tzinfo is not None:  # a naive time: add_measurement says so
        stored_twin(session.connection(), rig_id, rig_version_id, measured_at, record)
    stored_series_twin(session.connection(), rig_id, rig_version_id, [record])
    measurement = add_measurement(session, rig_id=rig_id, measured_at=measured_at,
                                  record=record)
    diagnosis = Diagnosis(
        measurement=measurement,
        records=[measurement],
        rig_version_id=rig_version_id,
        component=component,
        probability=probability,
        result=dict(result),
        estimates=[estimate_row(e, result) for e in estimates],
    )
    session.add(diagnosis)
    return diagnosis


def estimate_row(e: ComponentEstimate, result: Mapping[str, Any]) -> DiagnosisEstimate:
    """The stored row of one estimate; an interval not given is read from ``result``."""
    return DiagnosisEstimate(
        component=e.component, probability=e.probability, clearance_m=e.clearance_m,
        slip_coefficient=e.slip_coefficient,
        low=e.low if e.low is not None else stated_bound(result, e.component, "low"),
        high=e.high if e.high is not None else stated_bound(result, e.component, "high"))


def record_diagnosis(
    session: Session,
    *,
    rig_id: int,
    measured_at: datetime,
    record: Mapping[str, Any],
    result: Mapping[str, Any],
    component: str | None,
    probability: float | None,
    estimates: Sequence[ComponentEstimate] = (),
    rig_version: int | None = None,
) -> Diagnosis:
    """Store a measurement and its diagnosis together.

    Parameters
    ----------
    rig_id
        The rig measured.
    measured_at
        When it was measured (timezone-aware).
    record, result
        The measurement record and the diagnosis result, as JSON-ready mappings.
    component, probability
        The most likely faulty component and its probability [1] (``None``: undecided).
    estimates
        Per-suspect estimates, one per component.
    rig_version
        Version of the rig description used; the latest when ``None``.
    """
    diagnosis = add_diagnosis(
        session, rig_id=rig_id, measured_at=measured_at, record=record, result=result,
        component=component, probability=probability, estimates=estimates,
        rig_version=rig_version,
    )
    commit(session, conflict="the diagnosis could not be stored")
    return diagnosis


def component_history(
    session: Session,
    rig_id: int,
    component: str,
    *,
    since: datetime | None = None,
    until: datetime | None = None,
) -> list[HistoryPoint]:
    """Return the estimates for ``component`` of rig ``rig_id`` in order of measurement."""
    get_rig(session, rig_id)
    statement = (
        select(Diagnosis.id, Measurement.measured_at, RigVersion.version,
               DiagnosisEstimate.probability, DiagnosisEstimate.clearance_m,
               DiagnosisEstimate.slip_coefficient, Diagnosis.component,
               DiagnosisEstimate.low, DiagnosisEstimate.high)
        .join(Diagnosis, DiagnosisEstimate.diagnosis_id == Diagnosis.id)
        .join(Measurement, Diagnosis.measurement_id == Measurement.id)
        .join(RigVersion, Diagnosis.rig_version_id == RigVersion.id)
        .where(Measurement.rig_id == rig_id, DiagnosisEstimate.component == component,
               current_diagnoses())
        .order_by(Measurement.measured_at, Diagnosis.id)
    )
    if since is not None:
        statement = statement.where(Measurement.measured_at >= since)
    if until is not None:
        statement = statement.where(Measurement.measured_at <= until)
    # plain columns, not ORM objects: a long history is read without building an entity
    # per row (the trends page reads every component's history)
    return [HistoryPoint(*row) for row in session.execute(statement)]
