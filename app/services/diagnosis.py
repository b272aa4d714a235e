"""Diagnose measurement records against their rig and keep them in the history.

Used by ``POST /diagnose`` and ``hydrodiag diagnose``.  Every record of a request is
validated and diagnosed before anything is written; then all records and results are
stored in one transaction, so a request that fails stores nothing.

``diagnostics`` keeps its signature maps and steady-state evaluators in process-wide,
locked caches; an evaluator also keeps the last operating point it solved as the next
Newton start.  :data:`DIAGNOSIS_LOCK` serialises the calls so that two requests do not
interleave those starting points (the interpreter lock serialises the numerical work
anyway, so nothing is lost).
"""

from __future__ import annotations

import re
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from functools import partial
from typing import Any, TypeVar

from sqlalchemy.orm import Session

from app.db.base import utcnow
from app.schemas.diagnose import (
    DiagnoseRequest,
    MeasurementIn,
)
from app.services.common import commit, prefixed
from app.services.diagnosis_estimates import EstimateOut, estimates_of, json_ready
from app.services.history import (
    add_diagnosis,
    add_measurement,
    stored_series_twin,
)
from app.services.measurements import stored_record, to_record
from app.services.rig_cache import ResolvedRig, RigCache
from app.services.series import check_source
from diagnostics.diagnose import diagnose
from diagnostics.measurement import MeasurementRecord
from sim.errors import InputError
from sim.rigs import Rig

__all__ = ["DIAGNOSIS_LOCK", "STORE_CONFLICT", "UNEXPLAINED", "DiagnosisOutcome", "EstimateOut",
           "GroupPlan", "GroupResult", "add_outcomes", "compute_group", "diagnose_request",
           "each_or_refused", "each_refused", "estimates_of", "json_ready", "outcome_of",
           "plan_groups", "raise_refused", "request_error", "store_outcomes"]

#: Serialises calls into ``diagnostics`` within one process (module docstring).
DIAGNOSIS_LOCK = threading.Lock()

#: Message of a stored diagnosis refused by a constraint of the store.
STORE_CONFLICT = "the diagnosis could not be stored"

#: ``top`` and ``component`` of a diagnosis whose readings no hypothesis explains.
UNEXPLAINED = "unexplained"


@dataclass
class DiagnosisOutcome:
    """The diagnosis of one record or of a joint batch, and where it was stored."""

    paths: list[str]
    resolved: ResolvedRig
    measured_at: datetime
    top: str
    component: str
    probability: float
    estimates: list[EstimateOut]
    result: dict[str, Any]
    diagnosis_id: int | None = None
    measurement_ids: list[int] = field(default_factory=list)


def _request_field(field: str | None, group: Sequence[tuple[str, object]]) -> str | None:
    """Path in the request of a field that ``diagnose`` named within its records."""
    if field is None:
        return None
    match = re.match(r"^records\[(\d+)\]\.?(.*)$", field)
    if match is not None and len(group) > 1:
        return prefixed(group[int(match.group(1))][0], match.group(2) or None)
    if field == "records":
        return group[0][0] if len(group) == 1 else "records"
    return prefixed(group[0][0], field)


T = TypeVar("T")
R = TypeVar("R")


def each_refused(items: Sequence[T], work: Callable[[T], R]
                 ) -> tuple[list[R], list[InputError]]:
    """``work`` of every item, and the refusals (an :class:`InputError`: an invalid record,
    one impossible on its rig) of those it refused, instead of stopping at the first."""
    done: list[R] = []
    refused: list[InputError] = []
    for item in items:
        try:
            done.append(work(item))
        except InputError as exc:
            refused.append(exc)
    return done, refused


def _index(exc: InputError) -> int:
    match = re.match(r"^records\[(\d+)\]", exc.field or "")
    return int(match.group(1)) if match is not None else -1


def raise_refused(refused: Sequence[InputError]) -> None:
    """Nothing without refusals; else the first in request order raised, every one in its
    ``details`` and its message saying how many: a batch named one bad record, not the
    first, and the next only once that was fixed (a fleet integrator's pass)."""
    if not refused:
        return
    ordered = sorted(refused, key=_index)
    first = ordered[0]
    if len(ordered) > 1:
        first = type(first)(f"{first.message} (and {len(ordered) - 1} more refused: every one "
                            "is in details)", field=first.field)
        first.details = [{"field": e.field, "message": e.message} for e in ordered]
    raise first


def each_or_refused(items: Sequence[T], work: Callable[[T], R]) -> list[R]:
    """:func:`each_refused`, its refusals raised together (:func:`raise_refused`)."""
    done, refused = each_refused(items, work)
    raise_refused(refused)
    return done


def _groups(request: DiagnoseRequest) -> list[list[tuple[str, MeasurementIn]]]:
    items = request.items()
    if not request.joint:
        return [[item] for item in items]
    first = items[0][1]
    for path, record in items[1:]:
        if record.rig_id != first.rig_id:
            raise InputError("a joint diagnosis needs records of one rig", field=f"{path}.rig_id")
    stated = [(path, r.rig_version) for path, r in items if r.rig_version is not None]
    for path, version in stated[1:]:
        if version != stated[0][1]:
            raise InputError("a joint diagnosis needs one version of the rig document",
                             field=f"{path}.rig_version")
    return [items]


def _diagnosable(resolved: ResolvedRig, path: str) -> None:
    try:
        resolved.rig.require_cycle("a diagnosis")
    except InputError as exc:
        raise type(exc)(exc.message, field=f"{path}.rig_id") from None


def joint_rig(session: Session, rigs: RigCache, rig_id: int,
              versions: Sequence[tuple[str, int | None]]) -> ResolvedRig:
    """The rig version of a group of records (``versions``: each record's path and stated
    version): the one they state, a record stating none meaning the latest.  A group whose
    stated version is not the latest and has a record stating none is refused, naming that
    record (it means another version); one stating version 1 beside one stating none, both
    meaning version 1, was refused before.

    A rig that cannot be diagnosed at all (no cylinder cycle) says so here, before its
    records are read: a ZeMA rig's record was first asked for a load force it has not.

    Raises
    ------
    NotFoundError, CircuitError, InputError
        An unknown rig or version; a rig without a cylinder cycle; a record meaning
        another version.
    """
    path0 = versions[0][0]
    stated = next(((p, v) for p, v in versions if v is not None), None)
    if stated is None:
        resolved = rigs.get(session, rig_id, None, rig_field=f"{path0}.rig_id",
                            version_field=f"{path0}.rig_version")
        _diagnosable(resolved, path0)
        return resolved
    resolved = rigs.get(session, rig_id, stated[1], rig_field=f"{path0}.rig_id",
                        version_field=f"{stated[0]}.rig_version")
    _diagnosable(resolved, path0)
    unstated = [p for p, v in versions if v is None]
    if unstated:
        latest = rigs.get(session, rig_id, None, rig_field=f"{path0}.rig_id").version
        if latest != resolved.version:
            raise InputError(f"states no rig version, so the latest ({latest}), while "
                             f"{stated[0]} states version {resolved.version}: a joint "
                             "diagnosis needs one version of the rig document",
                             field=f"{unstated[0]}.rig_version")
    return resolved


@dataclass(frozen=True, slots=True)
class GroupResult:
    """The computed half of a diagnosis: plain data, picklable (it crosses processes).

    ``field`` of an error raised while computing it is within the group's records
    (``records[1].flow_B``); :func:`outcome_of` maps it to the request's path.
    """

    top: str
    component: str
    probability: float
    estimates: list[EstimateOut]
    result: dict[str, Any]


def compute_group(rig: Rig, records: Sequence[MeasurementRecord], rig_version: int
                  ) -> GroupResult:
    """Diagnose ``records`` jointly on ``rig`` and shape the result as the API returns it.

    Pure computation (no store, no locks): runs in the service's diagnosis processes
    (:mod:`app.services.diagnosis_pool`) or, under :data:`DIAGNOSIS_LOCK`, in a thread.

    Raises
    ------
    InputError
        The records cannot be diagnosed on this rig (``field`` within the records).
    """
    diagnosis = diagnose(rig, list(records))
    top = diagnosis.top
    explained = diagnosis.explained
    estimates = estimates_of(diagnosis)
    result = json_ready(diagnosis.to_dict())
    result["estimates"] = {e.component: {"quantity": e.quantity, "unit": e.unit,
                                         "value": e.value, "low": e.low, "high": e.high,
                                         "probability": e.probability, "source": e.source}
                           for e in estimates}
    result["rig_version"] = rig_version
    return GroupResult(
        top=top.name if explained else UNEXPLAINED,
        component=("+".join(top.hypothesis.components) or "healthy") if explained
        else UNEXPLAINED,
        probability=top.probability if explained else 0.0, estimates=estimates, result=result)


@dataclass(frozen=True, slots=True)
class GroupPlan:
    """One group of a request, resolved against the store and ready to compute.

    ``group`` holds each record's path in the request and the record (a
    :class:`~app.schemas.diagnose.MeasurementIn`, or its
    :class:`~app.services.diagnosis_form.RecordForm`).
    """

    group: Sequence[tuple[str, object]]
    resolved: ResolvedRig
    times: list[datetime]
    records: list[MeasurementRecord]


def plan_groups(session: Session, rigs: RigCache, request: DiagnoseRequest, now: datetime
                ) -> list[GroupPlan]:
    """Resolve each group's rig and build its diagnostics records (no diagnosis yet).

    Raises
    ------
    NotFoundError, MeasurementError, InputError
        An unknown rig or version, or an invalid record (``field`` is its path).
    """
    return each_or_refused(_groups(request), partial(_plan, session, rigs, now))


def _plan(session: Session, rigs: RigCache, now: datetime,
          group: list[tuple[str, MeasurementIn]]) -> GroupPlan:
    resolved = joint_rig(session, rigs, group[0][1].rig_id,
                         [(path, record.rig_version) for path, record in group])
    for path, record in group:
        if record.series_id is not None:
            check_source(session, record.series_id, record.rig_id, field=f"{path}.series_id")
    times = [record.measured_at or now for _, record in group]
    records = [to_record(record, path=path, rig_name=resolved.name, measured_at=t)
               for (path, record), t in zip(group, times, strict=True)]
    return GroupPlan(group, resolved, times, records)


def request_error(exc: InputError, plan: GroupPlan) -> InputError:
    """``exc`` (raised by :func:`compute_group`) with its field as a path in the request."""
    return type(exc)(exc.message, field=_request_field(exc.field, plan.group))


def latest_record(times: Sequence[datetime]) -> int:
    """Index of the record a joint result belongs to: the latest (the last of equals)."""
    return max(range(len(times)), key=lambda i: (times[i], i))


def outcome_of(plan: GroupPlan, computed: GroupResult) -> DiagnosisOutcome:
    """The outcome of a planned group from its computed result; the result says which of
    the group's records it is stored with (``record_index``: per-record lists such as each
    hypothesis's ``predicted`` are in the group's order)."""
    return DiagnosisOutcome(
        paths=[path for path, _ in plan.group], resolved=plan.resolved,
        measured_at=max(plan.times), top=computed.top, component=computed.component,
        probability=computed.probability, estimates=computed.estimates,
        result=computed.result | {"record_index": latest_record(plan.times)})


def _compute_locked(plan: GroupPlan) -> DiagnosisOutcome:
    try:
        with DIAGNOSIS_LOCK:
            computed = compute_group(plan.resolved.rig, plan.records, plan.resolved.version)
    except InputError as exc:
        raise request_error(exc, plan) from None
    return outcome_of(plan, computed)


def add_outcomes(session: Session, request: DiagnoseRequest,
                 outcomes: Sequence[DiagnosisOutcome], now: datetime) -> None:
    """Add the records and results of ``request`` to ``session`` and flush them (no
    commit); fills each outcome's ``diagnosis_id`` and ``measurement_ids``.

    Repeatable: run again on a fresh session after a rollback it adds the same rows anew
    (:class:`~app.services.group_commit.GroupCommitter` relies on that).
    """
    records = dict(request.items())
    for outcome in outcomes:
        # a joint result belongs to the latest record; the others are kept beside it
        times = [records[p].measured_at or now for p in outcome.paths]
        latest = latest_record(times)
        rows: list[Any] = []
        for i, path in enumerate(outcome.paths):
            record = stored_record(records[path], times[i])
            if i == latest:
                diagnosis = add_diagnosis(
                    session, rig_id=outcome.resolved.rig_id, measured_at=times[i],
                    record=record, result=outcome.result, component=outcome.component,
                    probability=outcome.probability,
                    estimates=[e.history() for e in outcome.estimates],
                    rig_version_id=outcome.resolved.version_id,
                    stated=records[path].measured_at is not None,
                )
                rows.append(diagnosis.measurement)
            else:
                stored_series_twin(session.connection(), outcome.resolved.rig_id,
                                   outcome.resolved.version_id, [record])
                rows.append(add_measurement(session, rig_id=outcome.resolved.rig_id,
                                            measured_at=times[i], record=record))
        diagnosis.records = rows  # a joint diagnosis is linked to each of its records
        session.flush()
        outcome.diagnosis_id = diagnosis.id
        outcome.measurement_ids = [row.id for row in rows]


def diagnose_request(session: Session, rigs: RigCache, request: DiagnoseRequest,
                     now: datetime | None = None) -> list[DiagnosisOutcome]:
    """Diagnose the records of ``request`` and store them unless ``request.store`` is false.

    Parameters
    ----------
    session
        Session of the store.
    rigs
        The compiled rigs of the service (or of the command line).
    request
        One record or a batch, each diagnosed alone or all jointly.
    now
        The time of the request, that of records without one [UTC] (default: now).

    Returns
    -------
    list of DiagnosisOutcome
        One per record, or one for a joint batch, in request order.

    Raises
    ------
    NotFoundError
        A record names an unknown rig or version (``field`` is its path).
    MeasurementError
        A record is invalid or impossible on its rig (``field`` is its path).
    """
    now = now or utcnow()
    plans, refused = each_refused(_groups(request), partial(_plan, session, rigs, now))
    outcomes, impossible = each_refused(plans, _compute_locked)
    raise_refused([*refused, *impossible])
    if request.store:
        store_outcomes(session, request, outcomes, now)
    return outcomes


def store_outcomes(session: Session, request: DiagnoseRequest,
                   outcomes: Sequence[DiagnosisOutcome], now: datetime) -> None:
    """Store the records and results of ``request`` in one transaction (all or nothing);
    fills each outcome's ``diagnosis_id`` and ``measurement_ids``.

    ``now`` is the time the request was planned at (that of records without one).
    """
    try:
        add_outcomes(session, request, outcomes, now)
        commit(session, conflict=STORE_CONFLICT)
    except Exception:
        session.rollback()
        raise
