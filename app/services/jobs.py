"""Jobs: long work run by worker threads, with status and progress kept in the store.

A job function takes its parameters and a :class:`Progress` reporter and returns a
JSON-ready result::

    def sweep(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        for i, case in enumerate(cases):
            ...
            progress((i + 1) / len(cases), f"case {i + 1} of {len(cases)}")
        return {"cases": ...}

    job = runner.submit("sweep", params, sweep)   # returns at once; GET /jobs/{id} follows it

Sweeps and re-diagnoses fan their CPU-heavy work out to processes (or a Dask cluster)
through :class:`~app.services.executors.SweepExecutors`; a discrepancy job runs in its
thread, in compiled simulations and numpy that hold the interpreter lock for a few
milliseconds at a time: another thread of the process (``/health``) waits at most about
Python's 5 ms switch interval beside it (``make job-stall``: p99 5.0-5.5 ms on a quiet
machine, against the 20 ms /health target).  Compiled code that releases the lock
(``nogil``) took that p99 to 1.7-2.3 ms in the same runs, but is not used: the compiled
code was written for one thread at a time, and what its callers share between threads has
not been audited.

A job can be cancelled (:func:`cancel_job`, ``POST /jobs/{id}/cancel``): a queued one at
once (it never starts); a running one is asked to stop — ``cancel_requested_at`` is set in
the store, which every server process shares — and stops at its next progress report
(one that is written, every :data:`PROGRESS_STEP` of progress, or one :data:`CANCEL_LOOK_S`
after the last look), where :class:`Progress` raises :class:`JobCancelledError` (a job
function that fans work out cancels what has not started on its way out).  A job that
finishes before it looks keeps its result.

Each job is owned by the :class:`JobRunner` (one per server process) that runs it and held
by a lease (``owner``, ``lease_until``) that the runner renews every :data:`RENEW_S` while
the job is queued or running.  A job whose lease has run out (its process stopped or was
killed) is marked failed by :func:`fail_interrupted_jobs`, which every runner calls at its
start and with each renewal: within :data:`LEASE_S` of the stop when another process
serves the store, or when the service starts again.  Until revision 0009 a starting
process failed every unfinished job of the store, so a second instance on one database
failed the jobs of the first while they ran and threw away their results.

A stopping service (:meth:`JobRunner.shutdown`) fails its queued jobs at once, saying they
never started, gives its running ones :data:`SHUTDOWN_GRACE_S` to finish, and fails those
still running (asked to stop at their next progress report); either is submitted again.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
import time
import uuid
from collections.abc import Callable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as futures_wait
from datetime import timedelta
from typing import Any

from sqlalchemy import func, literal, select, update

from app.db.base import utcnow
from app.db.engine import SessionFactory
from app.db.models import Job
from app.errors import ServiceBusyError
from app.services.heap import trim_heap
from app.services.job_retention import DEFAULT_RETENTION_DAYS, prune_finished_jobs
from app.services.job_rows import (
    CANCELLED_ERROR,
    cancel_job,
    fail_interrupted_jobs,
    get_job,
    list_jobs,
)
from sim.errors import HydrodiagError

__all__ = ["LEASE_S", "RENEW_S", "JobCancelledError", "JobFunction", "JobRunner", "Progress",
           "cancel_job", "fail_interrupted_jobs", "get_job", "list_jobs"]

logger = logging.getLogger("hydrodiag.jobs")

#: Smallest change of progress that is written to the store [1].
PROGRESS_STEP = 0.01
#: Longest time between two looks for a cancel while a job reports [s].
CANCEL_LOOK_S = 0.5
#: How long a stopping service lets its running jobs finish before failing them [s]
#: (docker stop's default is 10 s, after which the process is killed).
SHUTDOWN_GRACE_S = 5.0
#: Retry-After of a job refused because the process has as many as it takes [s]
JOB_RETRY_AFTER_S = 30

#: How long a job's lease lasts after its runner last renewed it [s].
LEASE_S = 60.0
#: How often a runner renews the leases of its jobs (and fails those whose lease ran out) [s].
RENEW_S = 15.0


class JobCancelledError(Exception):
    """Raised in a running job by :class:`Progress` once a cancel was asked of it.

    Outside the :mod:`sim.errors` tree on purpose: it is the job runner's own signal to
    stop, caught by :meth:`JobRunner._run`, never an answer of the service."""


class Progress:
    """Reports a job's progress to the store; call it with a fraction in [0, 1].

    Writes are skipped until the fraction has grown by :data:`PROGRESS_STEP`, so a job may
    report after every case without flooding the store.  A write that finds a cancel asked
    of the job (``cancel_requested_at`` set) raises :class:`JobCancelledError` instead: the
    same statement writes and looks.  A skipped write still looks for a cancel when the last
    look is :data:`CANCEL_LOOK_S` old, so a job whose fraction grows slowly stops as soon.
    """

    def __init__(self, sessions: SessionFactory, job_id: str) -> None:
        self._sessions = sessions
        self._job_id = job_id
        self._written = 0.0
        self._looked = time.monotonic()

    def __call__(self, fraction: float, message: str | None = None) -> None:
        """Record that ``fraction`` [1] of the work is done, with an optional note."""
        if not 0.0 <= fraction <= 1.0:
            raise ValueError(f"progress must lie in [0, 1], got {fraction}")
        now = time.monotonic()
        if fraction - self._written < PROGRESS_STEP and fraction < 1.0:
            if now - self._looked >= CANCEL_LOOK_S:
                self.check()
            return
        self._written = fraction
        self._looked = now
        with self._sessions() as session:
            written = session.execute(
                update(Job)
                .where(Job.id == self._job_id, Job.cancel_requested_at.is_(None))
                .values(progress=fraction, message=message, updated_at=utcnow())
            )
            session.commit()
        if not getattr(written, "rowcount", 1):
            raise JobCancelledError(self._job_id)

    def check(self) -> None:
        """Look for a cancel asked of the job now (a stopping service asks its late jobs):
        raise :class:`JobCancelledError` if there is one.  Before a job's last write (a
        discrepancy job's new rig version), so a job failed at a stop stores nothing."""
        self._looked = time.monotonic()
        with self._sessions() as session:
            asked = session.scalar(select(Job.cancel_requested_at)
                                   .where(Job.id == self._job_id))
        if asked is not None:
            raise JobCancelledError(self._job_id)


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
    retention_days
        A finished job is deleted this long after it finished [d], when a later job is
        submitted (:mod:`app.services.job_retention`); 0 keeps every job.
    """

    def __init__(self, sessions: SessionFactory, *, workers: int,
                 renew_s: float = RENEW_S, max_queued: int | None = None,
                 retention_days: float = DEFAULT_RETENTION_DAYS) -> None:
        self._sessions = sessions
        #: a finished job's row is deleted this long after it finished [d] (0: kept)
        self._retention_days = retention_days
        self._workers = workers
        #: jobs kept waiting beside the running ones (None: no bound)
        self._max_queued = max_queued
        self._executor = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="job")
        #: who runs this runner's jobs: host, process and a token (a respawned worker may
        #: reuse a pid)
        self.owner = f"{socket.gethostname()[:32]}:{os.getpid()}:{uuid.uuid4().hex[:8]}"
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._submitting = threading.Lock()
        self._futures: list[Future[None]] = []
        self._renewer = threading.Thread(target=self._renew_loop, args=(renew_s,),
                                         name="job-leases", daemon=True)
        self._renewer.start()

    def renew(self) -> int:
        """Extend the lease of this runner's queued and running jobs by :data:`LEASE_S`
        and fail the jobs of the store whose lease ran out; return how many were failed."""
        with self._sessions() as session:
            session.execute(
                update(Job)
                .where(Job.owner == self.owner, Job.status.in_(("queued", "running")))
                .values(lease_until=utcnow() + timedelta(seconds=LEASE_S)))
            session.commit()
            return fail_interrupted_jobs(session)

    def _renew_loop(self, every: float) -> None:
        while not self._stop.wait(every):
            try:
                failed = self.renew()
            except Exception as exc:  # the store unreachable for a while: try again
                logger.warning("could not renew the job leases: %s", type(exc).__name__)
                continue
            if failed:
                logger.warning("%d job(s) whose process stopped marked failed", failed)

    def submit(self, kind: str, params: Mapping[str, Any], function: JobFunction) -> Job:
        """Store a queued job and schedule ``function(params, progress)``.

        Returns
        -------
        Job
            The stored row (status ``queued``); follow it with :func:`get_job`.

        Raises
        ------
        ServiceBusyError
            As many jobs running and waiting in this process as it takes (``workers`` and
            ``max_queued``); nothing is stored.
        """
        with self._submitting:  # the count and the new job's place as one step: parallel
            # submits took 38-41 jobs against a bound of 36 (a verification pass)
            if self._max_queued is not None:
                with self._lock:
                    pending = sum(1 for f in self._futures if not f.done())
                if pending >= self._workers + self._max_queued:
                    raise ServiceBusyError(
                        f"{pending} jobs are running or waiting in this server process, as "
                        f"many as it takes ({self._workers} running, "
                        f"HYDRODIAG_MAX_QUEUED_JOBS {self._max_queued} waiting); nothing "
                        "was stored: retry later, or cancel a job",
                        retry_after=JOB_RETRY_AFTER_S)
            job = Job(
                id=str(uuid.uuid4()), kind=kind, status="queued", progress=0.0,
                params=dict(params), owner=self.owner,
                lease_until=utcnow() + timedelta(seconds=LEASE_S),
            )
            with self._sessions() as session:
                prune_finished_jobs(session, self._retention_days)
                session.add(job)
                session.commit()
            future: Future[None] = self._executor.submit(self._run, job.id, dict(params),
                                                         function)
            future.add_done_callback(_log_crash)
            future.add_done_callback(trim_heap)  # what the job freed, back to the system
            with self._lock:
                self._futures = [f for f in self._futures if not f.done()] + [future]
        return job

    def _set(self, job_id: str, *, when: str | None = None, **values: Any) -> bool:
        """Update job ``job_id`` (only while its status is ``when``, if given); whether a
        row was updated."""
        statement = update(Job).where(Job.id == job_id)
        if when is not None:
            statement = statement.where(Job.status == when)
        with self._sessions() as session:
            done = session.execute(statement.values(updated_at=utcnow(), **values))
            session.commit()
        return bool(getattr(done, "rowcount", 1))

    def _run(self, job_id: str, params: dict[str, Any], function: JobFunction) -> None:
        if not self._set(job_id, when="queued", status="running", started_at=utcnow()):
            return  # cancelled while it waited for a thread
        try:
            result = dict(function(params, Progress(self._sessions, job_id)))
        except JobCancelledError:
            # its last stage said as where it stopped ("point 57 of 200" alone read as a
            # job still at work: an operator pass)
            self._set(job_id, when="running", status="cancelled", finished_at=utcnow(),
                      error=CANCELLED_ERROR, message=func.substr(
                          literal("cancelled on request at ")
                          + func.coalesce(Job.message, "its start"), 1, 500))
            return
        except Exception as exc:
            if not isinstance(exc, HydrodiagError):
                logger.exception("job %s failed", job_id)
            self._set(job_id, when="running", status="failed", error=_error_of(exc),
                      finished_at=utcnow())
            return
        self._set(job_id, when="running", status="succeeded", progress=1.0, result=result,
                  finished_at=utcnow())

    def shutdown(self, *, wait: bool = True, grace_s: float = SHUTDOWN_GRACE_S) -> None:
        """Stop taking jobs.  This runner's queued jobs, which will not run, are failed at
        once saying so (they sat ``queued`` for a lease and then read "its lease ran
        out"; an operator pass); with ``wait``, the running ones get ``grace_s`` [s] to
        finish, and those still running are failed and asked to stop at their next progress
        report (a stop waited 22 s for two discrepancy jobs, past docker's 10 s)."""
        self._executor.shutdown(wait=False, cancel_futures=True)
        self._fail_mine("queued", "the service stopped before this job started; submit it "
                        "again")
        if wait:
            with self._lock:
                running = [f for f in self._futures if not f.done()]
            _, late = futures_wait(running, timeout=grace_s)
            if late:
                self._fail_mine("running", f"the service stopped while this job ran (it "
                                f"was given {grace_s:g} s to finish); submit it again",
                                cancel=True)
        self._stop.set()

    def _fail_mine(self, status: str, message: str, *, cancel: bool = False) -> None:
        """Fail this runner's jobs in ``status`` with ``message``; with ``cancel``, ask them
        to stop too."""
        now = utcnow()
        extra = {"cancel_requested_at": now} if cancel else {}
        try:
            with self._sessions() as session:
                done = session.execute(
                    update(Job).where(Job.owner == self.owner, Job.status == status)
                    .values(status="failed", finished_at=now, updated_at=now, **extra,
                            message=message[:500],
                            error={"type": "ServiceStoppedError", "message": message,
                                   "field": None}))
                session.commit()
        except Exception as exc:  # the store away: the leases run out instead
            logger.warning("could not mark the %s jobs at shutdown: %s", status,
                           type(exc).__name__)
            return
        if count := getattr(done, "rowcount", 0):
            logger.warning("%d %s job(s) failed at shutdown: %s", count, status, message)


def _log_crash(future: Future[None]) -> None:
    exc = future.exception() if not future.cancelled() else None
    if exc is not None:
        logger.error("job bookkeeping failed: %s", exc)
