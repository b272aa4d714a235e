"""Jobs: the runner keeps status and progress in the store; GET /jobs follows them."""

from __future__ import annotations

import re
import threading
import time
from typing import Any

import pytest

from app.db.models import Job
from app.services.jobs import JobRunner, Progress
from sim.errors import SimulationError
from tests.app.jobs_support import reports_until_cancelled
from tests.app.live import LiveServer, live_server, store_settings

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
    # a listing leaves the results out (a sweep's is megabytes) unless asked for them
    assert not listed["results"] and all(j["result"] is None for j in listed["items"])
    full = server.client.get("/jobs", params={"kind": "listed", "results": "true"}).json()
    one = server.client.get(f"/jobs/{ids[0]}").json()
    assert full["results"] and {j["id"]: j["result"] for j in full["items"]}[ids[0]] == \
        one["result"] is not None
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
    settings = store_settings(tmp_path_factory.mktemp("restart"))
    with live_server(settings) as first, first.session() as session:
        session.add(Job(id="11111111-1111-1111-1111-111111111111", kind="sweep",
                        status="running", progress=0.4, params={}))
        session.commit()
    with live_server(settings) as second:
        body = second.client.get("/jobs/11111111-1111-1111-1111-111111111111").json()
        assert body["status"] == "failed"
        assert body["error"]["type"] == "ServiceUnavailableError"
        assert body["progress"] == 0.4


def test_a_running_job_stops_at_its_next_progress_report(server: LiveServer) -> None:
    started = threading.Event()
    job = server.app.state.jobs.submit("endless", {}, reports_until_cancelled(started, POLL_TIMEOUT_S))
    assert started.wait(POLL_TIMEOUT_S)
    asked = server.client.post(f"/jobs/{job.id}/cancel")
    assert asked.status_code == 202, asked.text
    assert asked.json()["cancel_requested_at"] is not None
    assert asked.json()["status"] in ("running", "cancelled")
    done = _wait_for(server, job.id, {"succeeded", "failed", "cancelled"})
    assert done["status"] == "cancelled"
    assert done["error"] == {"type": "JobCancelledError", "message": "cancelled on request",
                             "field": None}
    assert done["result"] is None
    # its last stage is no longer its message (an operator read "case 3 of 10" on it)
    # (progress is written every 1 %: "its start" when the cancel came before the first)
    assert re.fullmatch(r"cancelled on request at (step \d+|its start)", done["message"])
    assert done["cancel_requested_at"] <= done["finished_at"]
    # it stopped where it was: the progress stored is the last written before the cancel
    # (writes come every 1 %: 0 when the cancel came before the first)
    assert 0.0 <= done["progress"] < 0.9
    # asking again changes nothing; the list finds it by its status
    again = server.client.post(f"/jobs/{job.id}/cancel")
    assert again.status_code == 202 and again.json()["status"] == "cancelled"
    assert again.json()["finished_at"] == done["finished_at"]
    listed = server.client.get("/jobs", params={"status": "cancelled", "kind": "endless"})
    assert [j["id"] for j in listed.json()["items"]] == [job.id]


def test_a_queued_job_is_cancelled_before_it_starts(server: LiveServer) -> None:
    release = threading.Event()
    ran: list[str] = []

    def blocks(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        release.wait(POLL_TIMEOUT_S)
        return {}

    def records(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        ran.append("ran")
        return {}

    runner: JobRunner = server.app.state.jobs
    blockers = [runner.submit("blocker", {}, blocks) for _ in range(server.settings.job_workers)]
    for b in blockers:
        _wait_for(server, b.id, {"running"})
    waiting = runner.submit("waiting", {}, records)
    assert server.client.get(f"/jobs/{waiting.id}").json()["status"] == "queued"
    cancelled = server.client.post(f"/jobs/{waiting.id}/cancel")
    assert cancelled.status_code == 202
    body = cancelled.json()
    assert (body["status"], body["started_at"], body["cancel_requested_at"]) == (
        "cancelled", None, None)
    assert body["finished_at"] is not None and body["message"] == "cancelled on request"
    release.set()
    for b in blockers:
        assert _wait_for(server, b.id, {"succeeded", "failed"})["status"] == "succeeded"
    time.sleep(0.1)  # the freed thread takes the cancelled job and must leave it alone
    assert ran == []
    assert server.client.get(f"/jobs/{waiting.id}").json()["status"] == "cancelled"


def test_finished_unknown_and_keyless_cancels_are_refused(server: LiveServer) -> None:
    runner: JobRunner = server.app.state.jobs
    job = runner.submit("short", {"n": 3}, _sum_of_squares)
    _wait_for(server, job.id, {"succeeded"})
    refused = server.client.post(f"/jobs/{job.id}/cancel")
    assert refused.status_code == 409
    assert refused.json()["error"]["field"] == "job_id"
    assert "succeeded" in refused.json()["error"]["message"]
    after = server.client.get(f"/jobs/{job.id}").json()
    assert (after["status"], after["cancel_requested_at"]) == ("succeeded", None)
    assert server.client.post(
        "/jobs/00000000-0000-0000-0000-000000000000/cancel").status_code == 404
    assert server.anon.post(f"/jobs/{job.id}/cancel").status_code == 401



def test_a_job_whose_progress_grows_slowly_still_stops(server: LiveServer) -> None:
    """A job reporting the same fraction again and again (no write is due) looks for a
    cancel every CANCEL_LOOK_S all the same."""
    started = threading.Event()

    def stuck(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        deadline = time.monotonic() + POLL_TIMEOUT_S
        while time.monotonic() < deadline:
            progress(0.0, "still at the start")
            started.set()
            time.sleep(0.005)
        return {"ran": "to its deadline"}

    job = server.app.state.jobs.submit("stuck", {}, stuck)
    assert started.wait(POLL_TIMEOUT_S)
    assert server.client.post(f"/jobs/{job.id}/cancel").status_code == 202
    done = _wait_for(server, job.id, {"succeeded", "failed", "cancelled"})
    assert (done["status"], done["result"]) == ("cancelled", None)
    assert done["progress"] == 0.0


def test_past_the_jobs_a_process_takes_a_job_is_503_and_nothing_is_stored(
        tmp_path_factory: pytest.TempPathFactory) -> None:
    """100 sweeps of 200 transient points were all accepted at once, each holding server
    memory while it waited (an SRE pass): past ``job_workers`` running and
    ``max_queued_jobs`` waiting, a job is a 503 with Retry-After and nothing is stored."""
    from app.errors import ServiceBusyError
    from tests.app.test_scenarios import SWEEP

    settings = store_settings(tmp_path_factory.mktemp("queue"), job_workers=1,
                               max_queued_jobs=1)
    release = threading.Event()

    def blocks(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        release.wait(POLL_TIMEOUT_S)
        return {}

    with live_server(settings) as server:
        runner: JobRunner = server.app.state.jobs
        running = runner.submit("blocker", {}, blocks)
        _wait_for(server, running.id, {"running"})
        waiting = runner.submit("blocker", {}, blocks)
        before = server.row_counts()
        with pytest.raises(ServiceBusyError) as busy:
            runner.submit("blocker", {}, blocks)
        assert "HYDRODIAG_MAX_QUEUED_JOBS 1" in busy.value.message
        refused = server.client.post("/scenarios", json=SWEEP, headers=server.auth)
        assert refused.status_code == 503, refused.text
        assert int(refused.headers["retry-after"]) > 0
        assert server.row_counts() == before
        release.set()
        for job in (running, waiting):
            assert _wait_for(server, job.id, {"succeeded", "failed"})["status"] == "succeeded"
        assert server.client.post("/scenarios", json=SWEEP,
                                  headers=server.auth).status_code == 202


def test_a_last_look_before_a_jobs_final_write_finds_a_cancel(server: LiveServer) -> None:
    """A discrepancy job failed at a stop with "submit it again" had stored its rig version
    all the same (an SRE pass): nothing looked for a cancel between its last progress
    report and its store.  ``check`` looks, and the job stores nothing."""
    release = threading.Event()
    stored: list[str] = []

    def slow_then_stores(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        progress(0.5, "working")
        release.wait(POLL_TIMEOUT_S)
        progress.check()  # no report between: only this look can find the cancel
        stored.append("version")
        return {}

    runner: JobRunner = server.app.state.jobs
    job = runner.submit("stores", {}, slow_then_stores)
    _wait_for(server, job.id, {"running"})
    assert server.client.post(f"/jobs/{job.id}/cancel").status_code == 202
    release.set()
    assert _wait_for(server, job.id, {"cancelled", "succeeded", "failed"})["status"] == \
        "cancelled"
    assert stored == []
