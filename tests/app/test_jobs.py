"""Jobs: the runner keeps status and progress in the store; GET /jobs follows them."""

from __future__ import annotations

import threading
import time
from typing import Any

import pytest

from app.db.models import Job
from app.services.jobs import JobRunner, Progress
from sim.errors import SimulationError
from tests.app.live import LiveServer, live_server, sqlite_settings

POLL_TIMEOUT_S = 30.0


def _wait_for(server: LiveServer, job_id: str, statuses: set[str]) -> dict[str, Any]:
    deadline = time.monotonic() + POLL_TIMEOUT_S
    while True:
        body = server.client.get(f"/jobs/{job_id}").json()
        if body["status"] in statuses:
            return dict(body)
        if time.monotonic() > deadline:
            raise AssertionError(f"job {job_id} stuck in {body['status']}")
        time.sleep(0.02)


def _sum_of_squares(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
    total = 0
    for i in range(params["n"]):
        total += i * i
        progress((i + 1) / params["n"], f"term {i + 1} of {params['n']}")
    return {"sum": total}


def test_a_job_runs_to_success_with_progress(server: LiveServer) -> None:
    runner: JobRunner = server.app.state.jobs
    job = runner.submit("sum", {"n": 300}, _sum_of_squares)
    done = _wait_for(server, job.id, {"succeeded", "failed"})
    assert done["status"] == "succeeded", done
    assert done["result"] == {"sum": sum(i * i for i in range(300))}
    assert done["progress"] == 1.0
    assert done["message"] == "term 300 of 300"
    assert done["params"] == {"n": 300}
    assert done["error"] is None
    assert done["created_at"] <= done["started_at"] <= done["finished_at"]


def test_progress_is_visible_while_running(server: LiveServer) -> None:
    halfway, release = threading.Event(), threading.Event()

    def two_halves(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        progress(0.5, "first half done")
        halfway.set()
        release.wait(POLL_TIMEOUT_S)
        return {}

    job = server.app.state.jobs.submit("halves", {}, two_halves)
    assert halfway.wait(POLL_TIMEOUT_S)
    running = server.client.get(f"/jobs/{job.id}").json()
    assert (running["status"], running["progress"], running["message"]) == (
        "running", 0.5, "first half done")
    assert running["finished_at"] is None
    release.set()
    assert _wait_for(server, job.id, {"succeeded", "failed"})["status"] == "succeeded"


def test_failures_are_recorded_with_the_error_body(server: LiveServer) -> None:
    def diverges(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        raise SimulationError("step size underflow at t = 0.31 s", field="solver.dt")

    def crashes(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        return {"x": 1 / params["zero"]}

    runner: JobRunner = server.app.state.jobs
    failed = _wait_for(server, runner.submit("sim", {}, diverges).id, {"succeeded", "failed"})
    assert failed["status"] == "failed"
    assert failed["error"] == {"type": "SimulationError", "field": "solver.dt",
                               "message": "step size underflow at t = 0.31 s"}
    crashed = _wait_for(server, runner.submit("sim", {"zero": 0}, crashes).id,
                        {"succeeded", "failed"})
    assert crashed["error"]["type"] == "InternalError"
    assert "division" not in crashed["error"]["message"]  # internals stay in the log


def test_list_and_unknown(server: LiveServer) -> None:
    runner: JobRunner = server.app.state.jobs
    ids = [runner.submit("listed", {"n": n}, _sum_of_squares).id for n in (1, 2, 3)]
    for job_id in ids:
        _wait_for(server, job_id, {"succeeded"})
    listed = server.client.get("/jobs", params={"kind": "listed", "status": "succeeded"}).json()
    assert listed["total"] == 3
    assert sorted(j["id"] for j in listed["items"]) == sorted(ids)
    assert server.client.get("/jobs", params={"status": "lost"}).status_code == 422
    missing = server.client.get("/jobs/00000000-0000-0000-0000-000000000000")
    assert missing.status_code == 404
    assert missing.json()["error"] == {"type": "NotFoundError", "field": "job_id",
                                       "message": "no job with id "
                                       "00000000-0000-0000-0000-000000000000",
                                       "request_id": missing.headers["X-Request-ID"]}


def test_progress_must_be_a_fraction(server: LiveServer) -> None:
    def overshoots(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        progress(1.5)
        return {}

    job = server.app.state.jobs.submit("bad-progress", {}, overshoots)
    assert _wait_for(server, job.id, {"succeeded", "failed"})["status"] == "failed"


def test_jobs_cut_off_by_a_stop_are_marked_failed_at_start(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    settings = sqlite_settings(tmp_path_factory.mktemp("restart"))
    with live_server(settings) as first, first.session() as session:
        session.add(Job(id="11111111-1111-1111-1111-111111111111", kind="sweep",
                        status="running", progress=0.4, params={}))
        session.commit()
    with live_server(settings) as second:
        body = second.client.get("/jobs/11111111-1111-1111-1111-111111111111").json()
        assert body["status"] == "failed"
        assert body["error"]["type"] == "ServiceUnavailableError"
        assert body["progress"] == 0.4
