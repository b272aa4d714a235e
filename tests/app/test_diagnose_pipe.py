"""``POST /diagnose`` as a thin pipe: rows stored by Core inserts read back as the models
read them, stored ids spliced into the answer, the key checked on the event loop (a
revoked key stops at once), admission by expected wait, and a killed diagnosis process
replaced."""

from __future__ import annotations

import asyncio
import os
import signal
import time
from datetime import datetime

import pytest
from sqlalchemy import select

from app.db.models import Diagnosis, DiagnosisEstimate, Measurement
from app.errors import ServiceBusyError
from app.security import Scope
from app.services.diagnosis_pipes import Process, Queued, take_message
from app.services.diagnosis_pool import DiagnosisPool
from app.services.keys import create_api_key, revoke_api_key
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer

WORN_VALVE = {"valve.cv": 60e-6}


def test_stored_rows_read_back_as_answered(server: LiveServer) -> None:
    """Joint batch of two records: two measurements, one diagnosis on the latest, its
    estimates; ids in the answer are the stored ones; the stored result is the full one."""
    early = simulated_record(server, WORN_VALVE, measured_at="2026-05-01T08:00:00Z")
    late = simulated_record(server, WORN_VALVE, measured_at="2026-05-01T09:00:00Z")
    response = server.client.post("/diagnose", json={"records": [late, early], "joint": True,
                                                      "compact": True})
    assert response.status_code == 200, response.text
    (answer,) = response.json()["diagnoses"]
    with server.session() as session:
        diagnosis = session.get(Diagnosis, answer["id"])
        assert diagnosis is not None
        measurements = [session.get(Measurement, i) for i in answer["measurement_ids"]]
        estimates = session.scalars(select(DiagnosisEstimate).where(
            DiagnosisEstimate.diagnosis_id == diagnosis.id)).all()
    assert all(m is not None for m in measurements)
    # the diagnosis belongs to the latest record, the first of the request
    assert diagnosis.measurement_id == answer["measurement_ids"][0]
    stored_times = [m.measured_at for m in measurements if m is not None]
    assert stored_times == [datetime.fromisoformat(r["measured_at"]) for r in (late, early)]
    assert measurements[1] is not None
    assert measurements[1].record["flow_B"] == {"value": early["flow_B"]}
    assert diagnosis.component == answer["component"]
    assert diagnosis.probability == pytest.approx(answer["probability"])
    assert {e.component for e in estimates} == {e["component"] for e in answer["estimates"]}
    for row in estimates:
        (sent,) = [e for e in answer["estimates"] if e["component"] == row.component]
        stored = row.clearance_m if sent["quantity"] in ("cc", "cv") else row.slip_coefficient
        assert stored == pytest.approx(sent["value"], rel=1e-12)
    # the compact answer leaves the predictions out; the stored result keeps them
    assert all("predicted" in h for h in diagnosis.result["hypotheses"])
    read = server.client.get(f"/diagnoses/{answer['id']}")
    assert read.status_code == 200, read.text
    assert read.json()["result"]["top"] == answer["result"]["top"]


def test_a_revoked_key_stops_storing_at_once(server: LiveServer) -> None:
    with server.session() as session:
        row, key = create_api_key(session, "pipe-writer", Scope.WRITE)
    record = simulated_record(server, WORN_VALVE)
    headers = {"X-API-Key": key}
    assert server.anon.post("/diagnose", json={"record": record},
                            headers=headers).status_code == 200
    with server.session() as session:
        revoke_api_key(session, row.id)
    before = server.row_counts()
    refused = server.anon.post("/diagnose", json={"record": record}, headers=headers)
    assert refused.status_code == 401, refused.text
    assert server.row_counts() == before


def test_a_read_key_may_diagnose_but_not_store(server: LiveServer) -> None:
    with server.session() as session:
        _, key = create_api_key(session, "pipe-reader", Scope.READ)
    record = simulated_record(server, WORN_VALVE)
    headers = {"X-API-Key": key}
    before = server.row_counts()
    assert server.anon.post("/diagnose", json={"record": record, "store": False},
                            headers=headers).status_code == 200
    refused = server.anon.post("/diagnose", json={"record": record}, headers=headers)
    assert refused.status_code == 403, refused.text
    assert server.row_counts() == before


def test_admission_refuses_once_the_expected_wait_passes_the_budget() -> None:
    pool = DiagnosisPool(2, wait_budget_s=0.05)
    pool.service_time_s = 0.02  # 20 ms a task, two processes: 10 ms per task ahead
    loop = asyncio.new_event_loop()
    try:
        for _ in range(5):  # 5 ahead: 50 ms, within the budget
            pool._pending.append(Queued(b"", loop.create_future()))
        assert pool.expected_wait_s() == pytest.approx(0.05)
        with pool.admit():
            assert pool.admitted == 1
        pool._pending.append(Queued(b"", loop.create_future()))  # 60 ms
        with pytest.raises(ServiceBusyError) as refused, pool.admit():
            pass
        assert refused.value.retry_after == 1
        assert pool.admitted == 0 and pool.refused_by_wait == 1
    finally:
        loop.close()


def test_the_service_time_leaves_out_cold_tasks_and_clamps_slow_ones() -> None:
    pool = DiagnosisPool(1)
    worker = Process(None, None)  # type: ignore[arg-type]
    for _ in range(3):  # cold first tasks: not learnt
        pool._learn(worker, 0.9)
    assert pool.service_time_s == 0.0
    pool._learn(worker, 0.010)
    assert pool.service_time_s == pytest.approx(0.010)
    pool._learn(worker, 10.0)  # a batch: taken as 4 times the mean at most
    assert pool.service_time_s == pytest.approx(0.010 + 0.1 * (0.040 - 0.010))


def test_messages_are_taken_whole_from_the_pipe_buffer() -> None:
    buffer = bytearray((5).to_bytes(4, "big") + b"hello" + (3).to_bytes(4, "big") + b"ab")
    assert take_message(buffer) == b"hello"
    assert take_message(buffer) is None  # the second is incomplete
    buffer += b"c"
    assert take_message(buffer) == b"abc"
    assert buffer == bytearray()


def test_a_killed_diagnosis_process_is_replaced(server: LiveServer) -> None:
    pool: DiagnosisPool = server.app.state.diagnosis_pool
    (pid,) = pool.worker_pids()
    os.kill(pid, signal.SIGKILL)
    record = simulated_record(server, WORN_VALVE)
    deadline = time.monotonic() + 120
    statuses = []
    while time.monotonic() < deadline:
        response = server.client.post("/diagnose", json={"record": record, "store": False})
        statuses.append(response.status_code)
        if response.status_code == 200:
            break
        assert response.status_code == 503, response.text
        time.sleep(0.2)
    assert statuses[-1] == 200, statuses
    (replacement,) = pool.worker_pids()
    assert replacement != pid


def test_the_stages_of_a_stored_diagnosis_are_timed(server: LiveServer) -> None:
    """``/metrics`` counts each stage of a stored diagnosis once more after one request:
    queue, compute (in the diagnosis process), transfer, commit, and the whole request;
    the compute time is within the request's, which is within the client's."""
    def counts() -> dict[str, float]:
        text = server.anon.get("/metrics").text
        found = {}
        for stage in ("queue", "compute", "transfer", "commit", "request"):
            for kind in ("count", "sum"):
                prefix = f'hydrodiag_diagnosis_stage_seconds_{kind}{{stage="{stage}"}} '
                lines = [x for x in text.splitlines() if x.startswith(prefix)]
                found[f"{stage}_{kind}"] = float(lines[0].split()[-1]) if lines else 0.0
        return found

    record = simulated_record(server, WORN_VALVE)
    before = counts()
    started = time.perf_counter()
    response = server.client.post("/diagnose", json={"record": record})
    elapsed = time.perf_counter() - started
    assert response.status_code == 200, response.text
    after = counts()
    for stage in ("queue", "compute", "transfer", "commit", "request"):
        assert after[f"{stage}_count"] == before[f"{stage}_count"] + 1, stage
    computed = after["compute_sum"] - before["compute_sum"]
    whole = after["request_sum"] - before["request_sum"]
    assert 0 < computed < whole < elapsed


def test_the_event_loop_reads_a_key_as_the_store_does(server: LiveServer) -> None:
    """The driver-level read of the event loop gives the row SQLAlchemy gives, its
    revocation time as an aware UTC time, and sees a revocation at once."""
    from app.security import split_key
    from app.services.keys import _key_row, _key_row_sqlite

    if server.engine.dialect.name != "sqlite":
        pytest.skip("the event loop's driver-level key read is SQLite's (PostgreSQL reads "
                    "keys through the pool)")
    with server.session() as session:
        row, key = create_api_key(session, "loop-reader", Scope.READ)
    prefix = split_key(key)
    assert prefix is not None
    fresh = _key_row_sqlite(server.engine, prefix)
    assert fresh == _key_row(server.engine, prefix) and fresh is not None
    assert fresh.revoked_at is None and fresh.scope == "read"
    with server.session() as session:
        revoke_api_key(session, row.id)
    revoked = _key_row_sqlite(server.engine, prefix)
    assert revoked == _key_row(server.engine, prefix) and revoked is not None
    assert revoked.revoked_at is not None and revoked.revoked_at.utcoffset() is not None
    assert _key_row_sqlite(server.engine, "0" * 12) is None
