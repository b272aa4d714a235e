"""Group commit of stored diagnoses: writes queued at once share one transaction, each is
answered only after its rows are committed, a failing write fails alone, and concurrent
stored ``POST /diagnose`` requests all land in the store."""

from __future__ import annotations

import asyncio
import threading
from concurrent.futures import ThreadPoolExecutor
from datetime import UTC, datetime, timedelta

import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.db.models import Measurement
from app.services.group_commit import GroupCommitter, Write
from app.services.history import add_measurement
from sim.errors import ConflictError
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer

T0 = datetime(2026, 3, 1, 8, 0, tzinfo=UTC)
UNKNOWN_RIG = 987_654


def _measurement(rig_id: int, minute: int) -> Write:
    def write(session: Session) -> None:
        add_measurement(session, rig_id=rig_id, measured_at=T0 + timedelta(minutes=minute),
                        record={"minute": minute})
        session.flush()
    return write


def _stored_minutes(server: LiveServer) -> set[int]:
    with server.session() as session:
        rows = session.scalars(select(Measurement).where(Measurement.measured_at >= T0)).all()
        return {int(row.record["minute"]) for row in rows if "minute" in row.record}


async def _queued_behind_a_blocker(committer: GroupCommitter, writes: list[Write]
                                   ) -> tuple[list[BaseException | None], bool]:
    """Hold the writer thread in a first write until ``writes`` are all queued, then let it
    go; return each write's outcome and whether any was answered before its commit."""
    inside, release = threading.Event(), threading.Event()

    def blocker(session: Session) -> None:
        inside.set()
        release.wait(30)
        _measurement(1, 0)(session)

    first = asyncio.ensure_future(committer.write(blocker, conflict="refused"))
    await asyncio.to_thread(inside.wait, 30)
    tasks = [asyncio.ensure_future(committer.write(w, conflict="refused")) for w in writes]
    await asyncio.sleep(0.05)  # every write is queued behind the blocker
    early = any(task.done() for task in tasks)
    release.set()
    await first
    results = await asyncio.gather(*tasks, return_exceptions=True)
    return [r if isinstance(r, BaseException) else None for r in results], early


def test_writes_queued_together_commit_in_one_transaction(server: LiveServer) -> None:
    committer = GroupCommitter(server.sessions)
    try:
        errors, early = asyncio.run(_queued_behind_a_blocker(
            committer, [_measurement(1, m) for m in range(1, 6)]))
    finally:
        committer.shutdown()
    assert errors == [None] * 5
    assert not early  # nothing answered before its transaction committed
    assert committer.transactions == 2  # the blocker alone, then the five queued together
    assert committer.committed == 6
    assert set(range(6)) <= _stored_minutes(server)


def test_a_failing_write_fails_alone_and_stores_nothing(server: LiveServer) -> None:
    committer = GroupCommitter(server.sessions)
    with server.session() as session:
        before = int(session.scalar(select(func.count()).select_from(Measurement)) or 0)
    try:
        errors, _ = asyncio.run(_queued_behind_a_blocker(committer, [
            _measurement(1, 101), _measurement(UNKNOWN_RIG, 102), _measurement(1, 103)]))
    finally:
        committer.shutdown()
    assert errors[0] is None and errors[2] is None
    assert isinstance(errors[1], ConflictError) and errors[1].message == "refused"
    stored = _stored_minutes(server)
    assert {101, 103} <= stored and 102 not in stored
    with server.session() as session:  # the blocker's and the two good writes' rows only
        after = int(session.scalar(select(func.count()).select_from(Measurement)) or 0)
    assert after - before == 3


def test_a_shut_down_committer_refuses_writes(server: LiveServer) -> None:
    committer = GroupCommitter(server.sessions)
    committer.shutdown()
    with pytest.raises(RuntimeError):
        asyncio.run(committer.write(_measurement(1, 200), conflict="refused"))


def test_concurrent_stored_diagnoses_all_land(server: LiveServer) -> None:
    n = 16
    base = simulated_record(server, {"valve.cv": 60e-6})
    bodies = [{"record": base | {"measured_at": f"2026-05-01T09:{i:02d}:00Z"}}
              for i in range(n)]
    writer: GroupCommitter = server.app.state.diagnosis_writer
    committed_before = writer.committed
    before = server.row_counts()
    # admission by expected wait would answer some of 16 at once with 503 on a slow
    # machine; this test is about the group commit, so the pool takes them all
    pool = server.app.state.diagnosis_pool
    budget, pool.wait_budget_s = pool.wait_budget_s, None
    try:
        with ThreadPoolExecutor(n) as threads:
            responses = list(threads.map(
                lambda body: server.client.post("/diagnose", json=body), bodies))
    finally:
        pool.wait_budget_s = budget
    assert [r.status_code for r in responses] == [200] * n, responses[0].text
    ids = [r.json()["diagnoses"][0]["id"] for r in responses]
    assert len(set(ids)) == n
    after = server.row_counts()
    assert after["diagnoses"] - before["diagnoses"] == n
    assert after["measurements"] - before["measurements"] == n
    assert writer.committed - committed_before == n
    for body, diagnosis_id in zip(bodies, ids, strict=True):
        stored = server.client.get(f"/diagnoses/{diagnosis_id}")
        assert stored.status_code == 200, stored.text
        assert stored.json()["measured_at"].startswith(body["record"]["measured_at"][:16])
