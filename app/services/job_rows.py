"""The stored job rows (:mod:`app.services.jobs`): reading, listing and cancelling them, and
failing those a stopped process left unfinished (a job's lease ran out, or its process on
this host is gone)."""

from __future__ import annotations

import os
import socket
from collections.abc import Sequence

from sqlalchemy import or_, select, update
from sqlalchemy.orm import Session, defer

from app.db.base import utcnow
from app.db.models import Job
from app.schemas.jobs import JobStatus
from app.services.common import get_or_raise, paginate
from sim.errors import ConflictError

__all__ = ["CANCELLED_ERROR", "cancel_job", "fail_interrupted_jobs", "get_job", "list_jobs"]

#: the ``error`` of a cancelled job
CANCELLED_ERROR = {"type": "JobCancelledError", "message": "cancelled on request", "field": None}


def cancel_job(session: Session, job_id: str) -> Job:
    """Cancel job ``job_id``: a queued one at once (status ``cancelled``), a running one by
    asking it to stop (``cancel_requested_at``; see the module docstring); asking again,
    or of a cancelled job, changes nothing.  Returns the job as it is then.

    Raises
    ------
    NotFoundError
        No such job.
    ConflictError
        The job has already succeeded or failed (before the cancel reached it).
    """
    job = get_job(session, job_id)
    if job.status in ("queued", "running"):
        now = utcnow()
        queued = session.execute(
            update(Job).where(Job.id == job_id, Job.status == "queued")
            .values(status="cancelled", finished_at=now, updated_at=now, error=CANCELLED_ERROR,
                    message=CANCELLED_ERROR["message"]))
        if not getattr(queued, "rowcount", 0):
            session.execute(
                update(Job).where(Job.id == job_id, Job.status == "running",
                                  Job.cancel_requested_at.is_(None))
                .values(cancel_requested_at=now, updated_at=now))
        session.commit()
        session.refresh(job)
    if job.status in ("succeeded", "failed"):
        raise ConflictError(f"job {job_id} has already finished ({job.status}); there is "
                            "nothing to cancel", field="job_id")
    return job


def get_job(session: Session, job_id: str) -> Job:
    """Return job ``job_id`` or raise :class:`~sim.errors.NotFoundError`."""
    return get_or_raise(session, Job, job_id, what="job", field="job_id")


def list_jobs(
    session: Session,
    *,
    limit: int,
    offset: int,
    status: JobStatus | None = None,
    kind: str | None = None,
    results: bool = True,
) -> tuple[Sequence[Job], int]:
    """Return a page of jobs, newest first; without ``results`` their ``result`` is not
    read (:func:`app.schemas.jobs.job_summary` shows them without: a 5,000-point sweep's
    is 3 MB, and a listing of seven jobs was 3.35 MB; an operator pass)."""
    statement = select(Job).order_by(Job.created_at.desc(), Job.id)
    if not results:
        statement = statement.options(defer(Job.result, raiseload=True))
    if status is not None:
        statement = statement.where(Job.status == status)
    if kind is not None:
        statement = statement.where(Job.kind == kind)
    return paginate(session, statement, limit=limit, offset=offset)


def _dead_owners(session: Session) -> list[str]:
    """Owners of unfinished jobs that were processes of this host and are gone (an owner is
    ``host:pid:tag``): after a ``kill -9`` their jobs read "running" for the lease's
    minute, and a cancel of one said "asked to stop" though nothing ran it (an operator's
    pass).  A pid that is alive keeps its lease (another service's, one of this service's
    processes — several apps share a process in the tests — or reused)."""
    host = socket.gethostname()[:32]
    owners = session.scalars(select(Job.owner).distinct().where(
        Job.status.in_(("queued", "running")), Job.owner.like(f"{host}:%"))).all()
    dead = []
    for owner in owners:
        try:
            pid = int(str(owner).split(":")[1])
        except (IndexError, ValueError):
            continue
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            dead.append(str(owner))
        except PermissionError:  # alive, another user's
            continue
    return dead


#: why a job whose process stopped failed (its ``error.message`` and ``message``)
_STOPPED = ("the process running the job stopped before it finished (it is gone, or its "
            "lease ran out); submit it again")


def fail_interrupted_jobs(session: Session) -> int:
    """Mark jobs left queued or running by a stopped process as failed (those asked to
    stop as cancelled): those whose lease ran out, or that have none (stored before
    revision 0009); return how many.  A job another live process runs keeps its lease."""
    now = utcnow()
    lapsed = or_(Job.lease_until.is_(None), Job.lease_until < now)
    dead = _dead_owners(session)
    if dead:  # this host's processes that are gone: their leases need not run out first
        lapsed = or_(lapsed, Job.owner.in_(dead))
    cancelled = session.execute(
        update(Job)
        .where(Job.status == "running", Job.cancel_requested_at.is_not(None), lapsed)
        .values(status="cancelled", finished_at=now, updated_at=now, error=CANCELLED_ERROR,
                message=CANCELLED_ERROR["message"], lease_until=None)
    )
    result = session.execute(
        update(Job)
        .where(Job.status.in_(("queued", "running")), lapsed)
        .values(
            status="failed",
            finished_at=now,
            updated_at=now,
            error={"type": "ServiceUnavailableError", "message": _STOPPED, "field": None},
            # the list's message column showed the last progress text, or nothing, for a
            # job failed so (an upgrade pass); a finished job holds no lease
            message=_STOPPED,
            lease_until=None,
        )
    )
    session.commit()
    return int(getattr(result, "rowcount", 0) or 0) + int(getattr(cancelled, "rowcount", 0)
                                                           or 0)
