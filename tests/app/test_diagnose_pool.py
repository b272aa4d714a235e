"""POST /diagnose computed in worker processes: same answers as in a thread, errors that
name their field, the compact answer, and workers that leave with a killed server."""

from __future__ import annotations

import asyncio
import json
import logging
import os
import signal
import subprocess
import sys
import textwrap
import time
from typing import Any

import pytest

from app.db.base import utcnow
from app.errors import ServiceBusyError
from app.schemas.diagnose import DiagnoseRequest
from app.services.diagnosis import GroupPlan, plan_groups
from app.services.diagnosis_pool import DiagnosisPool
from app.services.diagnosis_task import TaskFailure
from app.services.rig_cache import RigCache
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer

WORN_VALVE = {"valve.cv": 60e-6}


def test_the_service_diagnoses_in_a_worker_process(server: LiveServer) -> None:
    pool: DiagnosisPool = server.app.state.diagnosis_pool
    assert pool.processes == 1
    record = simulated_record(server, WORN_VALVE)
    response = server.client.post("/diagnose", json={"record": record, "store": False})
    assert response.status_code == 200, response.text
    assert response.json()["diagnoses"][0]["top"] == "valve"


def test_compact_leaves_out_the_predictions_and_the_store_keeps_them(
        server: LiveServer) -> None:
    record = simulated_record(server, WORN_VALVE, measured_at="2026-04-01T08:00:00Z")
    full = server.client.post("/diagnose", json={"record": record, "store": False})
    compact = server.client.post("/diagnose", json={"record": record, "compact": True})
    assert full.status_code == 200 and compact.status_code == 200, compact.text
    assert full.json()["compact"] is False and compact.json()["compact"] is True
    (f,), (c,) = full.json()["diagnoses"], compact.json()["diagnoses"]
    assert all("predicted" in h for h in f["result"]["hypotheses"])
    assert not any("predicted" in h for h in c["result"]["hypotheses"])
    # the same diagnosis: ranking, probabilities and estimates unchanged
    assert [h["name"] for h in c["result"]["hypotheses"]] == \
        [h["name"] for h in f["result"]["hypotheses"]]
    assert [h["probability"] for h in c["result"]["hypotheses"]] == pytest.approx(
        [h["probability"] for h in f["result"]["hypotheses"]], rel=1e-6, abs=1e-9)
    assert [(e["component"], e["source"]) for e in c["estimates"]] == \
        [(e["component"], e["source"]) for e in f["estimates"]]
    assert [e["value"] for e in c["estimates"]] == pytest.approx(
        [e["value"] for e in f["estimates"]], rel=1e-6)
    assert len(compact.content) < 0.9 * len(full.content)
    stored = server.client.get(f"/diagnoses/{c['id']}")
    assert stored.status_code == 200, stored.text
    assert all("predicted" in h for h in stored.json()["result"]["hypotheses"])


def test_an_error_raised_in_the_worker_names_its_field_and_stores_nothing(
        server: LiveServer) -> None:
    good = simulated_record(server, WORN_VALVE)
    # a load past the circuit's range: found by the diagnosis, in the worker
    stalled = good | {"condition": {"oil_temperature": 40.0, "load_force": 1.5e6}}
    before = server.row_counts()
    response = server.client.post("/diagnose", json={"records": [good, stalled]})
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == "records[1].condition.load_force"
    assert server.row_counts() == before


def _diagnose(pool: DiagnosisPool, server: LiveServer, body: dict[str, Any]) -> Any:
    request = DiagnoseRequest.model_validate(body)
    with server.session() as session:
        plans = plan_groups(session, RigCache(2), request, utcnow())
    resolved = [p.resolved for p in plans]
    pool.warm(resolved)
    return [asyncio.run(pool.compute(plan)) for plan in plans]


def test_a_worker_process_and_a_thread_give_the_same_diagnosis(server: LiveServer) -> None:
    body = {"records": [simulated_record(server, WORN_VALVE),
                        simulated_record(server, {"cylinder.cc": 120e-6})]}
    in_thread = _diagnose(DiagnosisPool(0), server, body)
    pool = DiagnosisPool(1)
    try:
        in_worker = _diagnose(pool, server, body)
    finally:
        pool.shutdown()
    assert [r.top for r in in_worker] == [r.top for r in in_thread] == ["valve", "cylinder"]
    for a, b in zip(in_worker, in_thread, strict=True):
        assert a.probability == pytest.approx(b.probability, rel=1e-6)
        assert [e.value for e in a.estimates] == pytest.approx([e.value for e in b.estimates],
                                                               rel=1e-6)


def test_a_worker_without_the_rig_is_sent_its_document_once(server: LiveServer) -> None:
    """Tasks carry the rig's key only; a worker that has not compiled the rig (warmed with
    none here) gets the document on a second send, then keeps the compiled rig."""
    body = {"record": simulated_record(server, WORN_VALVE)}
    request = DiagnoseRequest.model_validate(body)
    with server.session() as session:
        (plan,) = plan_groups(session, RigCache(2), request, utcnow())
    in_thread = _diagnose(DiagnosisPool(0), server, body)[0]
    pool = DiagnosisPool(1)
    try:
        pool.warm([])
        first = asyncio.run(pool.compute(plan))
        again = asyncio.run(pool.compute(plan))
    finally:
        pool.shutdown()
    for result in (first, again):
        assert result.top == in_thread.top == "valve"
        assert result.probability == pytest.approx(in_thread.probability, rel=1e-6)


def _worn_valve_plan(server: LiveServer) -> GroupPlan:
    """The planned group of one worn-valve record, as a pool computes it."""
    request = DiagnoseRequest.model_validate({"record": simulated_record(server, WORN_VALVE)})
    with server.session() as session:
        (plan,) = plan_groups(session, RigCache(2), request, utcnow())
    return plan


def test_a_process_killed_while_it_starts_is_replaced(server: LiveServer) -> None:
    # killed before it said ready (out of memory while warming): its pipe's EOF made every
    # later /diagnose a 500, for ever, with /ready at 200 (an operator pass)
    plan = _worn_valve_plan(server)
    restarts: list[int] = []
    pool = DiagnosisPool(1, on_restart=lambda: restarts.append(1))
    try:
        pool._start()
        first = pool._workers[0].process
        os.kill(first.pid, signal.SIGKILL)     # before it is ready: it imports for seconds
        (pid,) = pool.worker_pids()
        assert pid != first.pid and _alive(pid) and not _alive(first.pid)
        assert restarts == [1]   # counted (hydrodiag_diagnosis_process_restarts_total)
        assert asyncio.run(pool.compute(plan)).top == "valve"
    finally:
        pool.shutdown()


_KILLED_SERVER = textwrap.dedent("""
    import os, sys, time
    from app.services.diagnosis_pool import DiagnosisPool
    pool = DiagnosisPool(1)
    pool.warm([])
    print(pool.worker_pids()[0], flush=True)
    time.sleep(600)
""")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is gone for our purpose
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split()[2] != "Z"
    except FileNotFoundError:
        return False


def test_workers_leave_when_the_server_is_killed() -> None:
    parent = subprocess.Popen([sys.executable, "-c", _KILLED_SERVER], stdout=subprocess.PIPE,
                              text=True, env=os.environ | {"PYTHONPATH": os.getcwd()})
    try:
        assert parent.stdout is not None
        worker = int(parent.stdout.readline())
        assert _alive(worker)
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=30)
        deadline = time.monotonic() + 30
        while _alive(worker) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(worker)
    finally:
        if parent.poll() is None:
            parent.kill()


def test_admission_refuses_past_the_queue_and_counts_back_down() -> None:
    pool = DiagnosisPool(0, queue=2)
    with pool.admit(), pool.admit():
        assert pool.admitted == 2
        with pytest.raises(ServiceBusyError), pool.admit():
            pass
    assert pool.admitted == 0
    with pool.admit():
        assert pool.admitted == 1


def test_a_full_queue_is_503_with_retry_after_and_stores_nothing(server: LiveServer) -> None:
    record = simulated_record(server, WORN_VALVE)
    pool: DiagnosisPool = server.app.state.diagnosis_pool
    before = server.row_counts()
    pool.admitted += pool.queue  # as if that many requests were being diagnosed
    try:
        response = server.client.post("/diagnose", json={"record": record})
    finally:
        pool.admitted -= pool.queue
    assert response.status_code == 503, response.text
    assert response.headers["Retry-After"] == "1"
    assert response.json()["error"]["type"] == "ServiceBusyError"
    assert server.row_counts() == before
    assert server.client.post("/diagnose", json={"record": record}).status_code == 200


def test_the_warm_up_request_runs_whole_through_the_store(server: LiveServer) -> None:
    """What a diagnosis process runs before it says ready: an unstored request of the
    rig's healthy readings at its default condition, resolved through the store, whose
    top hypothesis is 'healthy' and which stores nothing."""
    from app.services.diagnosis_task import run_task
    from app.services.diagnosis_worker import warm_task

    rigs = RigCache(2)
    with server.session() as session:
        resolved = rigs.get(session, 1)
    task = warm_task(resolved.key, resolved.rig)
    assert task is not None and not task.form.store
    (record,) = task.form.records
    assert {"pump_pressure", "p1", "p2", "flow_B", "flow_C"} <= set(record.readings)
    before = server.row_counts()
    answer = run_task(server.sessions, rigs, task)
    assert not isinstance(answer, TaskFailure), answer
    (diagnosis,) = json.loads(answer.body())["diagnoses"]
    assert diagnosis["top"] == "healthy" and diagnosis["id"] is None
    assert answer.rows == [] and server.row_counts() == before


def test_a_stopped_worker_is_logged_without_the_id_of_the_request_that_woke_the_pool(
        server: LiveServer, caplog: pytest.LogCaptureFixture) -> None:
    """The pipe reader took the context of the request that first reached the pool, so the
    line "a diagnosis process stopped" named that request's id, minutes later."""
    from app.logs import _current, current_request_id

    plan = _worn_valve_plan(server)
    pool = DiagnosisPool(1)
    seen: list[str | None] = []

    class Spy(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            if "stopped; starting another" in record.getMessage():
                seen.append(current_request_id())

    spy = Spy()
    logging.getLogger("hydrodiag").addHandler(spy)

    async def scenario() -> None:
        token = _current.set("first-request")   # the request that wakes the pool
        try:
            await pool.compute(plan)
        finally:
            _current.reset(token)
        os.kill(pool.worker_pids()[0], signal.SIGKILL)
        deadline = time.monotonic() + 30
        while not seen and time.monotonic() < deadline:
            await asyncio.sleep(0.05)

    try:
        pool.warm([])
        asyncio.run(scenario())
    finally:
        logging.getLogger("hydrodiag").removeHandler(spy)
        pool.shutdown()
    assert seen == [None]


def test_a_process_that_died_idle_before_the_loop_watched_it_serves_the_next_request(
        server: LiveServer, monkeypatch: pytest.MonkeyPatch) -> None:
    """A diagnosis process killed while idle, before the pool's pipes were read from the
    loop, was found by the next request's write: a 500 BrokenPipeError (an operator's
    pass).  The request, not started, now waits for the replacement and is answered.  The
    kernel's answer to that write is made certain here (a copy of the pipe's far end held
    elsewhere for a moment, as under the test server, lets one write through)."""
    import app.services.diagnosis_pool as pool_module

    plan = _worn_valve_plan(server)
    restarts: list[int] = []
    pool = DiagnosisPool(1, on_restart=lambda: restarts.append(1))
    try:
        pool.warm([])                           # started and ready, not yet read by a loop
        (first,) = pool.worker_pids()
        dead = pool._workers[0].connection
        os.kill(first, signal.SIGKILL)
        send = pool_module.send_whole

        def broken(connection: Any, message: bytes) -> None:
            if connection is dead:
                raise BrokenPipeError(32, "Broken pipe")
            send(connection, message)

        monkeypatch.setattr(pool_module, "send_whole", broken)
        assert asyncio.run(pool.compute(plan)).top == "valve"
        assert restarts == [1] and pool.worker_pids()[0] != first
    finally:
        pool.shutdown()
