"""The jobs table is bounded: a finished job's row goes ``HYDRODIAG_JOB_RETENTION_DAYS``
after it finished, when a later job is submitted; unfinished and recent jobs stay."""

from __future__ import annotations

import uuid
from datetime import timedelta
from typing import Any

from sqlalchemy import func, select
from typer.testing import CliRunner

from app.cli import cli
from app.db.base import utcnow
from app.db.engine import SessionFactory, make_engine, make_session_factory
from app.db.models import Job
from app.services.job_retention import DEFAULT_RETENTION_DAYS
from app.services.jobs import JobRunner, get_job
from app.settings import Settings


def _store(runner: CliRunner) -> SessionFactory:
    assert runner.invoke(cli, ["db", "upgrade"]).exit_code == 0
    return make_session_factory(make_engine(Settings().url))


def _add(sessions: SessionFactory, status: str, finished_days_ago: float | None,
         kind: str = "old") -> str:
    """A job row of ``status`` that finished that many days ago (``None``: not finished)."""
    now = utcnow()
    finished = None if finished_days_ago is None else now - timedelta(days=finished_days_ago)
    job = Job(id=str(uuid.uuid4()), kind=kind, status=status, progress=1.0, params={},
              result={"payload": "x" * 1000}, created_at=finished or now,
              finished_at=finished, lease_until=now + timedelta(hours=1))
    with sessions() as session:
        session.add(job)
        session.commit()
    return job.id


def _ids(sessions: SessionFactory) -> set[str]:
    with sessions() as session:
        return set(session.scalars(select(Job.id)))


def _work(params: dict[str, Any], progress: Any) -> dict[str, Any]:
    return {"n": params["n"]}


def test_a_submit_deletes_the_jobs_finished_before_the_retention(runner: CliRunner) -> None:
    sessions = _store(runner)
    old = {_add(sessions, status, DEFAULT_RETENTION_DAYS + 1)
           for status in ("succeeded", "failed", "cancelled")}
    kept = {_add(sessions, "succeeded", DEFAULT_RETENTION_DAYS - 1),
            _add(sessions, "queued", None), _add(sessions, "running", None)}
    jobs = JobRunner(sessions, workers=1)
    try:
        new = jobs.submit("demo", {"n": 1}, _work)
    finally:
        jobs.shutdown()
    assert _ids(sessions) == kept | {new.id}
    assert not old & _ids(sessions)
    with sessions() as session:
        assert get_job(session, new.id).kind == "demo"


def test_the_rows_stay_bounded_over_many_jobs(runner: CliRunner) -> None:
    """200 jobs, each finishing (backdated) a day after the one before: at every submit
    the table holds only the jobs of the last retention period."""
    sessions = _store(runner)
    jobs = JobRunner(sessions, workers=1, retention_days=10.0)
    most = 0
    try:
        for day in range(200):
            _add(sessions, "succeeded", 200 - day)
            jobs.submit("demo", {"n": day}, _work)
            with sessions() as session:  # the backdated ones; the submitted finished now
                old = session.scalar(select(func.count()).select_from(Job).where(
                    Job.kind == "old"))
            most = max(most, int(old or 0))
    finally:
        jobs.shutdown()
    assert 1 <= most <= 10  # those finished within the last 10 days; 200 without the bound


def test_retention_zero_keeps_every_job(runner: CliRunner) -> None:
    sessions = _store(runner)
    old = _add(sessions, "succeeded", 10_000)
    jobs = JobRunner(sessions, workers=1, retention_days=0)
    try:
        jobs.submit("demo", {"n": 1}, _work)
    finally:
        jobs.shutdown()
    assert old in _ids(sessions)


def test_the_setting_reaches_the_service() -> None:
    assert Settings().job_retention_days == DEFAULT_RETENTION_DAYS
    assert Settings(job_retention_days=0).job_retention_days == 0
