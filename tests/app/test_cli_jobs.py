"""``hydrodiag jobs``: an operator lists, reads and cancels the service's jobs from its shell,
on the store the service uses (the cancel reaches a runner through the store)."""

from __future__ import annotations

import json
import threading
import time
from typing import Any

from typer.testing import CliRunner

from app.cli import cli
from app.db.engine import make_engine, make_session_factory
from app.services.jobs import JobRunner, get_job
from app.settings import Settings
from sim.errors import ConflictError, InputError, NotFoundError
from tests.app.jobs_support import reports_until_cancelled


def _status(sessions: Any, job_id: str) -> str:
    with sessions() as session:
        return get_job(session, job_id).status


def _until(sessions: Any, job_id: str, status: str, seconds: float = 30.0) -> None:
    deadline = time.monotonic() + seconds
    while _status(sessions, job_id) != status:
        assert time.monotonic() < deadline, _status(sessions, job_id)
        time.sleep(0.02)


def test_jobs_are_listed_shown_and_cancelled_from_the_shell(runner: CliRunner) -> None:
    assert runner.invoke(cli, ["db", "upgrade"]).exit_code == 0
    engine = make_engine(Settings().url)
    sessions = make_session_factory(engine)
    jobs = JobRunner(sessions, workers=1)   # a service's runner on the CLI's store
    try:
        started = threading.Event()
        running = jobs.submit("endless", {"n": 1}, reports_until_cancelled(started, 60.0))
        queued = jobs.submit("endless", {"n": 2}, reports_until_cancelled(threading.Event()))
        assert started.wait(30.0)
        listed = runner.invoke(cli, ["jobs", "list", "--json"])
        assert listed.exit_code == 0, listed.output
        by_id = {j["id"]: j for j in json.loads(listed.stdout)["items"]}
        assert by_id[running.id]["status"] == "running"
        assert by_id[queued.id]["status"] == "queued"
        table = runner.invoke(cli, ["jobs", "list", "--status", "running"])
        assert running.id in table.stdout and queued.id not in table.stdout
        # piped, each job stays on one line with its status whole (was "runn…" in 80 columns)
        (row,) = [line for line in table.stdout.splitlines() if running.id in line]
        assert " running " in row and "step " in row, table.stdout
        # a queued job is cancelled at once and never starts
        gone = runner.invoke(cli, ["jobs", "cancel", queued.id])
        assert gone.exit_code == 0 and "cancelled" in gone.stdout
        assert _status(sessions, queued.id) == "cancelled"
        # a running one is asked to stop, and stops at its next report
        asked = runner.invoke(cli, ["jobs", "cancel", running.id])
        assert asked.exit_code == 0 and "asked to stop" in asked.stdout, asked.output
        _until(sessions, running.id, "cancelled")
        shown = runner.invoke(cli, ["jobs", "show", running.id])
        assert "endless): cancelled" in shown.stdout and "JobCancelledError" in shown.stdout
        time.sleep(0.2)
        assert _status(sessions, queued.id) == "cancelled"   # the freed worker skipped it
        # finished, unknown and badly asked
        done = jobs.submit("quick", {}, lambda params, progress: {"answer": 42})
        _until(sessions, done.id, "succeeded")
        shown = runner.invoke(cli, ["jobs", "show", done.id, "--json"])
        assert json.loads(shown.stdout)["result"] == {"answer": 42}
        refused = runner.invoke(cli, ["jobs", "cancel", done.id])
        assert refused.exit_code != 0 and isinstance(refused.exception, ConflictError)
        unknown = runner.invoke(cli, ["jobs", "show", "no-such-job"])
        assert isinstance(unknown.exception, NotFoundError)
        bad = runner.invoke(cli, ["jobs", "list", "--status", "sleeping"])
        assert isinstance(bad.exception, InputError) and bad.exception.field == "--status"
    finally:
        jobs.shutdown(wait=True)
        engine.dispose()
