"""Jobs: long work run by worker threads, with status and progress kept in the store.

A job function takes its parameters and a :class:`Progress` reporter and returns a
JSON-ready result::

    def sweep(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        for i, case in enumerate(cases):
            ...
            progress((i + 1) / len(cases), f"case {i + 1} of {len(cases)}")
        return {"cases": ...}

    job = runner.submit("sweep", params, sweep)   # returns at once; GET /jobs/{id} follows it

The threads only orchestrate: CPU-heavy work inside a job fans out to processes (or a Dask
cluster) through the executor that ``diagnostics`` chooses.
"""

from __future__ import annotations

import logging
import uuid
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

from sqlalchemy import select, update
from sqlalchemy.orm import Session

from app.db.base import utcnow
from app.db.engine import SessionFactory
from app.db.models import Job
from app.schemas.jobs import JobStatus
from app.services.common import get_or_raise, paginate
from sim.errors import HydrodiagError

__all__ = ["JobFunction", "JobRunner", "Progress", "fail_interrupted_jobs", "get_job",
           "list_jobs"]

logger = logging.getLogger("hydrodiag.jobs")

#: Smallest change of progress that is written to the store [1].
PROGRESS_STEP = 0.01


class Progress:
    """Reports a job's progress to the store; call it with a fraction in [0, 1].

    Writes are skipped until the fraction has grown by :data:`PROGRESS_STEP`, so a job may
    report after every case without flooding the store.
    """

    def __init__(self, sessions: SessionFactory, job_id: str) -> None:
        self._sessions = sessions
        self._job_id = job_id
        self._written = 0.0

    def __call__(self, fraction: float, message: str | None = None) -> None:
        """Record that ``fraction`` [1] of the work is done, with an optional note."""
        if not 0.0 <= fraction <= 1.0:
            raise ValueError(f"progress must lie in [0, 1], got {fraction}")
        if fraction - self._written < PROGRESS_STEP and fraction < 1.0:
            return
        self._written = fraction
        with self._sessions() as session:
            session.execute(
                update(Job)
                .where(Job.id == self._job_id)
                .values(progress=fraction, message=message, updated_at=utcnow())
            )
            session.commit()


JobFunction = Callable[[dict[str, Any], Progress], Mapping[str, Any]]


def _error_of(exc: BaseException) -> dict[str, Any]:
    if isinstance(exc, HydrodiagError):
        return {"type": type(exc).__name__, "message": exc.message, "field": exc.field}
    return {"type": "InternalError", "message": "internal error; see the service log",
            "field": None}


class JobRunner:
    """Runs job functions on a pool of threads and keeps their state in the store.

    Parameters
    ----------
    sessions
        Session factory of the store.
    workers
        Number of jobs that run at the same time.
    """

    def __init__(self, sessions: SessionFactory, *, workers: int) -> None:
        self._sessions = sessions
        self._executor = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="job")

    def submit(self, kind: str, params: Mapping[str, Any], function: JobFunction) -> Job:
        """Store a queued job and schedule ``function(params, progress)``.

        Returns
        -------
        Job
            The stored row (status ``queued``); follow it with :func:`get_job`.
        """
        job = Job(
            id=str(uuid.uuid4()), kind=kind, status="queued", progress=0.0,
            params=dict(params),
        )
        with self._sessions() as session:
            session.add(job)
            session.commit()
        future: Future[None] = self._executor.submit(self._run, job.id, dict(params), function)
        future.add_done_callback(_log_crash)
        return job

    def _set(self, job_id: str, **values: Any) -> None:
        with self._sessions() as session:
            session.execute(update(Job).where(Job.id == job_id).values(updated_at=utcnow(),
                                                                          **values))
            session.commit()

    def _run(self, job_id: str, params: dict[str, Any], function: JobFunction) -> None:
        self._set(job_id, status="running", started_at=utcnow())
        try:
            result = dict(function(params, Progress(self._sessions, job_id)))
        except Exception as exc:
            if not isinstance(exc, HydrodiagError):
                logger.exception("job %s failed", job_id)
            self._set(job_id, status="failed", error=_error_of(exc), finished_at=utcnow())
            return
        self._set(job_id, status="succeeded", progress=1.0, result=result,
                  finished_at=utcnow())

    def shutdown(self, *, wait: bool = True) -> None:
        """Stop taking jobs; with ``wait``, let the running ones finish."""
        self._executor.shutdown(wait=wait, cancel_futures=True)


def _log_crash(future: Future[None]) -> None:
    exc = future.exception() if not future.cancelled() else None
    if exc is not None:
        logger.error("job bookkeeping failed: %s", exc)


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
) -> tuple[Sequence[Job], int]:
    """Return a page of jobs, newest first."""
    statement = select(Job).order_by(Job.created_at.desc(), Job.id)
    if status is not None:
        statement = statement.where(Job.status == status)
    if kind is not None:
        statement = statement.where(Job.kind == kind)
    return paginate(session, statement, limit=limit, offset=offset)


def fail_interrupted_jobs(session: Session) -> int:
    """Mark jobs left queued or running by a stopped service as failed; return how many."""
    now = utcnow()
    result = session.execute(
        update(Job)
        .where(Job.status.in_(("queued", "running")))
        .values(
            status="failed",
            finished_at=now,
            updated_at=now,
            error={"type": "ServiceUnavailableError",
                   "message": "the service stopped before the job finished; start it again",
                   "field": None},
        )
    )
    session.commit()
    return int(getattr(result, "rowcount", 0) or 0)
