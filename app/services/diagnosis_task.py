"""A whole ``POST /diagnose`` as one task for a diagnosis process: a validated form in,
answer out.

The server process of ``POST /diagnose`` is a thin pipe (issue 9): it validates the body
(FastAPI, so that a malformed request is the same 422 as ever), checks the key, and hands
the request's validated form (:class:`~app.services.diagnosis_form.RequestForm`: named
tuples of numbers, not validated again) to a diagnosis process as a :class:`DiagnoseTask`.
There :func:`run_task` resolves the rigs against the store (a session of that process's
own), builds the records, diagnoses them, and encodes the answer and the rows to store from
one encoding of each result (:func:`app.services.diagnosis_answer.answer_of`).  It answers
with a :class:`~app.services.diagnosis_answer.DiagnoseAnswer` (or a :class:`TaskFailure`
that names the field), plain data that pickles quickly; the server stores the rows
(:func:`app.services.diagnosis_rows.insert_rows`, SQLAlchemy Core) and splices the stored
ids into the answer's bytes.  Nothing of the diagnosis or its JSON runs in the server
process.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from functools import partial

from sqlalchemy.orm import Session

from app.db.engine import SessionFactory
from app.services.diagnosis import (
    GroupPlan,
    GroupResult,
    compute_group,
    each_or_refused,
    each_refused,
    joint_rig,
    outcome_of,
    raise_refused,
    request_error,
)
from app.services.diagnosis_answer import DiagnoseAnswer, StoredRows, answer_of
from app.services.diagnosis_form import RecordForm, RequestForm, measurement_record
from app.services.rig_cache import RigCache
from app.services.series import check_source
from sim.errors import HydrodiagError, InputError

__all__ = ["DiagnoseAnswer", "DiagnoseTask", "StoredRows", "TaskFailure", "plan_forms",
           "run_task"]


@dataclass(frozen=True, slots=True)
class DiagnoseTask:
    """One ``POST /diagnose`` for a diagnosis process.

    Attributes
    ----------
    form
        The request, validated by the server already.
    now
        Time of the request [UTC]: that of records without one.
    """

    form: RequestForm
    now: datetime


@dataclass(frozen=True, slots=True)
class TaskFailure:
    """An error of the library, carried back as plain data (its ``field`` survives)."""

    kind: type[HydrodiagError]
    message: str
    field: str | None
    details: list[dict[str, str | None]] | None = None

    @classmethod
    def of(cls, exc: HydrodiagError) -> TaskFailure:
        """The failure that carries ``exc``."""
        return cls(type(exc), exc.message, exc.field, exc.details)

    def error(self) -> HydrodiagError:
        """The error to raise in the server process."""
        exc = self.kind(self.message, field=self.field)
        exc.details = self.details
        return exc


def _groups(form: RequestForm) -> list[list[RecordForm]]:
    if form.mode != "joint":
        return [[record] for record in form.records]
    first = form.records[0]
    for record in form.records[1:]:
        if record.rig_id != first.rig_id:
            raise InputError("a joint diagnosis needs records of one rig",
                             field=f"{record.path}.rig_id")
    stated = [r for r in form.records if r.rig_version is not None]
    for record in stated[1:]:
        if record.rig_version != stated[0].rig_version:
            raise InputError("a joint diagnosis needs one version of the rig document",
                             field=f"{record.path}.rig_version")
    return [form.records]


def plan_forms(session: Session, rigs: RigCache, form: RequestForm, now: datetime
               ) -> list[GroupPlan]:
    """Resolve each group's rig and build its diagnostics records, as
    :func:`app.services.diagnosis.plan_groups` does for a validated model.

    Raises
    ------
    NotFoundError, MeasurementError, InputError
        An unknown rig or version, or an invalid record (``field`` is its path).
    """
    return each_or_refused(_groups(form), partial(_plan, session, rigs, now))


def _plan(session: Session, rigs: RigCache, now: datetime, group: list[RecordForm]
          ) -> GroupPlan:
    resolved = joint_rig(session, rigs, group[0].rig_id,
                         [(record.path, record.rig_version) for record in group])
    for record in group:
        if record.series_id is not None:
            check_source(session, record.series_id, record.rig_id,
                         field=f"{record.path}.series_id")
    times = [record.measured_at or now for record in group]
    records = [measurement_record(record, rig_name=resolved.name, measured_at=t)
               for record, t in zip(group, times, strict=True)]
    return GroupPlan([(r.path, r) for r in group], resolved, times, records)


def run_task(sessions: SessionFactory, rigs: RigCache, task: DiagnoseTask
             ) -> DiagnoseAnswer | TaskFailure:
    """Resolve, diagnose and encode the request of ``task`` (in a diagnosis process).

    Parameters
    ----------
    sessions
        Session factory of the store (to resolve the rigs; nothing is written).
    rigs
        The process's compiled rigs.
    task
        The request.

    Returns
    -------
    DiagnoseAnswer or TaskFailure
        The answer; or the error (unknown rig or version, a record impossible on its rig),
        its ``field`` a path in the request.
    """
    try:
        with sessions() as session:
            plans, refused = each_refused(_groups(task.form),
                                          partial(_plan, session, rigs, task.now))
        outcomes, impossible = each_refused(plans, lambda p: outcome_of(p, _computed(p)))
        raise_refused([*refused, *impossible])
        return answer_of(task.form, outcomes, task.now)
    except HydrodiagError as exc:
        return TaskFailure.of(exc)


def _computed(plan: GroupPlan) -> GroupResult:
    try:
        return compute_group(plan.resolved.rig, plan.records, plan.resolved.version)
    except InputError as exc:
        raise request_error(exc, plan) from None
