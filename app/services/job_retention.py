"""How long a finished job's row is kept: the jobs table's bound.

Every job — a sweep, a re-diagnosis, a discrepancy check — is a row of ``jobs`` with its
parameters and its whole result (a discrepancy report ~150 kB, a 5,000-point sweep a few
MB).  Nothing removed them: a soak run (``make soak``) stored 7 jobs per 1,000 requests,
0.2-0.3 MB of store each on average, for as long as the service ran.  A finished job
(succeeded, failed or cancelled) is now deleted :data:`DEFAULT_RETENTION_DAYS` after it
finished (``HYDRODIAG_JOB_RETENTION_DAYS``; 0 keeps every job), whenever a new job is
submitted (:meth:`app.services.jobs.JobRunner.submit`): the table then holds at most the
jobs finished within the retention period, plus those still queued or running.  What a job
stored elsewhere (a re-diagnosis's diagnoses, a commissioned version) is not touched; only
the job's own record of its progress and result goes.
"""

from __future__ import annotations

from datetime import datetime, timedelta

from sqlalchemy import delete
from sqlalchemy.orm import Session

from app.db.base import utcnow
from app.db.models import Job
from app.settings import DEFAULT_RETENTION_DAYS

__all__ = ["DEFAULT_RETENTION_DAYS", "FINISHED", "prune_finished_jobs"]

#: The statuses of a job that will not change again.
FINISHED = ("succeeded", "failed", "cancelled")


def prune_finished_jobs(session: Session, retention_days: float,
                        now: datetime | None = None) -> int:
    """Delete the jobs that finished more than ``retention_days`` [d] before ``now``
    (default: the present, UTC); return how many.  ``retention_days`` 0 deletes nothing.
    The caller commits."""
    if retention_days <= 0:
        return 0
    cutoff = (now or utcnow()) - timedelta(days=retention_days)
    done = session.execute(delete(Job).where(Job.status.in_(FINISHED),
                                             Job.finished_at < cutoff))
    return int(getattr(done, "rowcount", 0) or 0)
