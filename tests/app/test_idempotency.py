"""``Idempotency-Key``: a write resent after a timeout is answered once and stored once."""

from __future__ import annotations

import asyncio
import json
import threading
from datetime import timedelta
from pathlib import Path
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from sqlalchemy import update
from sqlalchemy.engine import make_url

from app.db import migrate
from app.db.base import utcnow
from app.db.engine import make_engine, make_session_factory
from app.db.models import IdempotentRequest
from app.idempotency import STALE_S, IdempotencyMiddleware, _digest, owner_of
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer

SERIES = b"t [s],phase,P1 [bar],x [m]\n0,working,10,0\n0.5,working,12,0.1\n1,working,12,0.2\n"


def _post_diagnose(server: LiveServer, record: dict[str, Any], key: str) -> httpx.Response:
    return server.client.post("/diagnose", json={"record": record},
                              headers=server.auth | {"Idempotency-Key": key})


def test_a_resent_diagnosis_is_answered_again_and_stored_once(server: LiveServer) -> None:
    record = simulated_record(server, {"valve.cv": 4.5e-5},
                              measured_at="2026-11-28T08:00:00Z")
    before = server.row_counts()
    first = _post_diagnose(server, record, "visit-2026-11-28-rig1")
    assert first.status_code == 200, first.text
    added = server.row_counts()
    assert added["diagnoses"] == before["diagnoses"] + 1
    again = _post_diagnose(server, record, "visit-2026-11-28-rig1")
    assert again.status_code == 200 and again.headers["Idempotent-Replayed"] == "true"
    assert again.json() == first.json()          # the same ids: nothing ran again
    assert server.row_counts() == added
    # the key on another request is refused, naming the header; nothing stored
    other = _post_diagnose(server, record | {"measured_at": "2026-11-28T09:00:00Z"},
                           "visit-2026-11-28-rig1")
    assert other.status_code == 422
    assert other.json()["error"]["field"] == "Idempotency-Key"
    assert server.row_counts() == added
    # a method the path does not take is the router's 405, whatever the key (it was the
    # key's 422: a fuzzer's PUT on /diagnose with a key used before)
    wrong_method = server.client.put("/diagnose", json={"record": record},
                                     headers=server.auth | {"Idempotency-Key":
                                                            "visit-2026-11-28-rig1"})
    assert wrong_method.status_code == 405, wrong_method.text
    # a key of other than 1-255 visible ASCII characters is refused
    bad = server.client.post("/diagnose", json={"record": record},
                             headers=server.auth | {"Idempotency-Key": "x y"})
    assert bad.status_code == 422 and bad.json()["error"]["field"] == "Idempotency-Key"
    # answered before routing, counted under their route all the same (were <unmatched>)
    metrics = server.client.get("/metrics").text
    assert 'method="POST",route="<unmatched>"' not in metrics
    assert 'method="POST",route="/diagnose",status="422"' in metrics


def test_a_failed_first_request_leaves_its_key_free(server: LiveServer) -> None:
    record = simulated_record(server)
    broken = record | {"pump_presure": 1.0e6}   # a misspelt field: 422
    refused = _post_diagnose(server, broken, "retry-after-fix")
    assert refused.status_code == 422
    fixed = _post_diagnose(server, record, "retry-after-fix")
    assert fixed.status_code == 200 and "Idempotent-Replayed" not in fixed.headers


def test_a_resent_series_import_is_stored_once(server: LiveServer) -> None:
    def send() -> httpx.Response:
        return server.client.post(
            "/rigs/1/series", data={"name": "resent", "started_at": "2026-11-20T08:00:00Z"},
            files={"file": ("cycle.csv", SERIES, "text/csv")},
            headers=server.auth | {"Idempotency-Key": "import-cycle-7"})

    first = send()
    assert first.status_code == 201, first.text
    counts = server.row_counts()
    again = send()
    assert again.status_code == 201 and again.json() == first.json()
    assert server.row_counts() == counts


def _app(tmp_path: Path, release: threading.Event) -> tuple[FastAPI, Any, list[int]]:
    """A slow endpoint behind the middleware on a store of its own, with a key whose
    plaintext is ``_app.key`` (a replay needs a valid key)."""
    from app.services.keys import create_api_key

    engine = make_engine(make_url(f"sqlite:///{tmp_path / 'idem.db'}"))
    migrate.upgrade(engine)
    sessions = make_session_factory(engine)
    with sessions() as session:
        _app.key = create_api_key(session, "client")[1]  # type: ignore[attr-defined]
    app = FastAPI()
    runs: list[int] = []

    @app.post("/slow", status_code=201)
    def slow() -> dict[str, int]:
        runs.append(1)
        assert release.wait(30)
        return {"run": len(runs)}

    app.add_middleware(IdempotencyMiddleware, sessions=sessions)
    return app, sessions, runs


def _post_slow(app: FastAPI, key: str, api_key: str | None = None) -> httpx.Response:
    """``POST /slow`` with ``Idempotency-Key: key`` and the app's own API key (or
    ``api_key``), through the ASGI transport."""
    async def post() -> httpx.Response:
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            return await client.post("/slow", json={}, headers={
                "Idempotency-Key": key,
                "X-API-Key": api_key or _app.key})  # type: ignore[attr-defined]

    return asyncio.run(post())


def _held_key(sessions: Any, key: str, *, quiet_s: float,
              stored_ago_s: float | None = None) -> None:
    """What a process killed while it ran ``POST /slow`` under ``key`` leaves: its row, last
    marked ``quiet_s`` ago, its work stored ``stored_ago_s`` ago (``None``: not stored)."""
    now = utcnow()
    with sessions() as session:
        session.add(IdempotentRequest(
            owner=owner_of(1), idempotency_key=key, method="POST", path="/slow",
            digest=_digest(b"POST", b"/slow", b"", b"application/json", b"{}"),
            created_at=now, touched_at=now - timedelta(seconds=quiet_s),
            expires_at=now + timedelta(hours=1),
            stored_at=None if stored_ago_s is None else now - timedelta(seconds=stored_ago_s)))
        session.commit()


def test_a_retry_while_the_first_request_runs_is_asked_to_wait(tmp_path: Path) -> None:
    release = threading.Event()
    app, _, runs = _app(tmp_path, release)
    headers = {"Idempotency-Key": "k1", "X-API-Key": _app.key}  # type: ignore[attr-defined]

    async def scenario() -> tuple[httpx.Response, httpx.Response, httpx.Response]:
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            first = asyncio.create_task(client.post("/slow", json={}, headers=headers))
            while not runs:
                await asyncio.sleep(0.01)
            waiting = await client.post("/slow", json={}, headers=headers)
            release.set()
            done = await first
            replay = await client.post("/slow", json={}, headers=headers)
            return waiting, done, replay

    waiting, done, replay = asyncio.run(scenario())
    assert waiting.status_code == 409 and waiting.headers["Retry-After"] == "2"
    assert done.status_code == 201 and replay.status_code == 201
    assert replay.json() == done.json() == {"run": 1} and len(runs) == 1


def test_a_first_request_whose_process_died_no_longer_blocks_its_key(tmp_path: Path) -> None:
    release = threading.Event()
    release.set()
    app, sessions, runs = _app(tmp_path, release)
    now = utcnow()
    with sessions() as session:   # what a process killed mid-request leaves
        session.add(IdempotentRequest(owner="?", idempotency_key="k2", method="POST",
                                      path="/slow", digest="?", created_at=now,
                                      touched_at=now, expires_at=now + timedelta(hours=1)))
        session.commit()

    with sessions() as session:   # the owner: the sender's key's rotation chain
        session.execute(update(IdempotentRequest).values(owner=owner_of(1)))
        session.commit()
    assert _post_slow(app, "k2").status_code == 422      # another request's digest
    same = _digest(b"POST", b"/slow", b"", b"application/json", b"{}")  # canonical JSON
    with sessions() as session:
        session.execute(update(IdempotentRequest).values(
            digest=same, touched_at=now - timedelta(seconds=STALE_S + 1)))
        session.commit()
    taken = _post_slow(app, "k2")
    assert taken.status_code == 201 and len(runs) == 1


def test_without_an_api_key_the_header_is_not_kept(tmp_path: Path) -> None:
    # anonymous clients (open reads store nothing) would share one owner: one's key could
    # replay another's answer
    release = threading.Event()
    release.set()
    app, sessions, _ = _app(tmp_path, release)

    async def twice() -> list[int]:
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            return [(await client.post("/slow", json={}, headers={"Idempotency-Key": "k3"})
                     ).json()["run"] for _ in range(2)]

    assert asyncio.run(twice()) == [1, 2]
    with sessions() as session:
        assert session.query(IdempotentRequest).count() == 0


def test_a_replay_needs_a_valid_key_and_json_written_otherwise_is_the_same_request(
        server: LiveServer) -> None:
    from app.services.keys import create_api_key, revoke_api_key

    with server.sessions() as session:
        row, plaintext = create_api_key(session, "short-lived", "write")
    record = simulated_record(server, measured_at="2026-11-28T10:00:00Z")
    headers = {"X-API-Key": plaintext, "Idempotency-Key": "visit-10h",
               "Content-Type": "application/json"}
    first = server.client.post("/diagnose", content=json.dumps({"record": record}),
                               headers=headers)
    assert first.status_code == 200, first.text
    # the same document, spaced and ordered otherwise: the same request, replayed
    other_spelling = json.dumps({"record": dict(reversed(list(record.items())))}, indent=2)
    again = server.client.post("/diagnose", content=other_spelling, headers=headers)
    assert again.status_code == 200 and again.headers["Idempotent-Replayed"] == "true"
    # a revoked key gets no answer from the store of kept answers (it got them 24 h)
    with server.sessions() as session:
        revoke_api_key(session, row.id)
    gone = server.client.post("/diagnose", content=json.dumps({"record": record}),
                              headers=headers)
    assert gone.status_code == 401 and "Idempotent-Replayed" not in gone.headers


def test_a_store_that_does_not_answer_is_a_503_for_a_keyed_write(tmp_path: Path) -> None:
    from sqlalchemy.exc import OperationalError

    release = threading.Event()
    release.set()
    app, _, runs = _app(tmp_path, release)

    def down() -> Any:
        raise OperationalError("SELECT 1", {}, ConnectionError("server closed the connection"))

    for m in app.user_middleware:   # the store goes away under the middleware
        if m.cls is IdempotencyMiddleware:
            m.kwargs["sessions"] = down

    async def post() -> httpx.Response:
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            return await client.post("/slow", json={}, headers={"Idempotency-Key": "k4",
                                                                "X-API-Key": "client-c"})

    response = asyncio.run(post())
    assert response.status_code == 503 and response.headers["Retry-After"] == "5"
    assert response.json()["error"]["type"] == "ServiceUnavailableError" and runs == []


def test_a_write_stored_whose_answer_was_lost_is_not_done_again(tmp_path: Path) -> None:
    # the process died after the work's transaction (which marked the key stored) and
    # before the answer was kept: the retry is refused, without Retry-After, not run again
    release = threading.Event()
    release.set()
    app, sessions, runs = _app(tmp_path, release)
    _held_key(sessions, "k5", quiet_s=STALE_S + 1, stored_ago_s=40.0)

    refused = _post_slow(app, "k5")
    assert refused.status_code == 409 and "Retry-After" not in refused.headers
    error = refused.json()["error"]
    assert error["field"] == "Idempotency-Key" and "stored at" in error["message"]
    assert runs == []


def _keeping_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """The middleware's own keeping of answers as a process killed before it: nothing."""
    monkeypatch.setattr(IdempotencyMiddleware, "_keep", lambda self, *args: None)


def test_a_diagnosis_keeps_its_answer_with_its_rows(server: LiveServer,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    # the answer is kept in the group transaction that stores the rows: a process killed
    # between that commit and the answer leaves a replayable key, not a doubled batch
    _keeping_nothing(monkeypatch)
    record = simulated_record(server, {"cylinder.cc": 1.2e-4},
                              measured_at="2026-11-29T06:00:00Z")
    first = _post_diagnose(server, record, "killed-after-commit")
    assert first.status_code == 200, first.text
    counts = server.row_counts()
    again = _post_diagnose(server, record, "killed-after-commit")
    assert again.status_code == 200 and again.headers["Idempotent-Replayed"] == "true"
    assert again.content == first.content and server.row_counts() == counts


def test_a_series_import_stored_before_a_crash_is_not_stored_again(
        server: LiveServer, monkeypatch: pytest.MonkeyPatch) -> None:
    _keeping_nothing(monkeypatch)
    headers = server.auth | {"Idempotency-Key": "import-killed"}

    def send() -> httpx.Response:
        return server.client.post(
            "/rigs/1/series", data={"name": "killed", "started_at": "2026-11-29T07:00:00Z"},
            files={"file": ("cycle.csv", SERIES, "text/csv")}, headers=headers)

    assert send().status_code == 201
    counts = server.row_counts()
    with server.sessions() as session:
        row = session.query(IdempotentRequest).filter_by(idempotency_key="import-killed").one()
        assert row.stored_at is not None and row.status is None
        row.touched_at = utcnow() - timedelta(seconds=STALE_S + 1)   # its process died
        session.commit()
    again = send()
    assert again.status_code == 409 and "Retry-After" not in again.headers
    assert server.row_counts() == counts


def test_a_retry_with_the_key_that_replaced_a_rotated_one_is_replayed(
        server: LiveServer) -> None:
    from app.services.keys import create_api_key, rotate_api_key

    with server.sessions() as session:
        row, old_key = create_api_key(session, "fleet-gateway", "write")
    record = simulated_record(server, measured_at="2026-11-29T08:00:00Z")
    body = {"record": record}
    first = server.client.post("/diagnose", json=body, headers={
        "X-API-Key": old_key, "Idempotency-Key": "gw-0800"})
    assert first.status_code == 200, first.text
    with server.sessions() as session:
        _, _, new_key = rotate_api_key(session, row.id, grace_s=60)
    counts = server.row_counts()
    again = server.client.post("/diagnose", json=body, headers={
        "X-API-Key": new_key, "Idempotency-Key": "gw-0800"})
    assert again.status_code == 200 and again.headers["Idempotent-Replayed"] == "true"
    assert again.content == first.content and server.row_counts() == counts
    # another client's key does not see it: its own request, run — and, the same record
    # stored already, refused as a twin (409) rather than replayed
    with server.sessions() as session:
        _, other_key = create_api_key(session, "other-client", "write")
    other = server.client.post("/diagnose", json=body, headers={
        "X-API-Key": other_key, "Idempotency-Key": "gw-0800"})
    assert other.status_code == 409 and "Idempotent-Replayed" not in other.headers
    assert "stored already" in other.json()["error"]["message"]


def test_a_deeply_nested_body_with_a_key_is_refused_as_without_one(server: LiveServer) -> None:
    # 2 KB, 1,000 levels deep: the key's canonical form hit the recursion limit, a 500
    deep = b'{"record": ' + b"[" * 1000 + b"]" * 1000 + b"}"
    headers = server.auth | {"Content-Type": "application/json"}
    plain = server.client.post("/diagnose", content=deep, headers=headers)
    keyed = server.client.post("/diagnose", content=deep,
                               headers=headers | {"Idempotency-Key": "deep-1"})
    assert plain.status_code == keyed.status_code == 422, keyed.text


def test_a_key_whose_process_stopped_marking_it_says_when_it_frees_itself(
        tmp_path: Path) -> None:
    # after a kill -9 and a restart the retry was told "still being processed, retry in
    # 2 s" for 30 s (an operator pass)
    release = threading.Event()
    release.set()
    app, sessions, runs = _app(tmp_path, release)
    _held_key(sessions, "k6", quiet_s=20.0)

    held = _post_slow(app, "k6")
    assert held.status_code == 409 and runs == []
    assert 8 <= int(held.headers["Retry-After"]) <= 10     # STALE_S 30 − 20 quiet
    assert "has most likely stopped" in held.json()["error"]["message"]
