"""The load benchmark's raw HTTP client against a real server: requests built as bytes are
answered as an HTTP client library would see them, bodies intact, connections reused."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from benchmarks import load_clients
from benchmarks.load_clients import Connection, closed_loop, open_loop, request_bytes
from tests.app.live import LiveServer, live_server, store_settings


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    with live_server(store_settings(Path(tmp_path_factory.mktemp("store")))) as live:
        yield live


def test_a_request_built_as_bytes_gets_the_same_answer_as_httpx(server: LiveServer) -> None:
    keyed = {"X-API-Key": server.key}

    async def exchange() -> list[tuple[int, bytes]]:
        connection = await Connection.open(server.base_url)
        try:  # three requests on one kept-alive connection
            return [await connection.exchange(request_bytes(server.base_url, "GET", path,
                                                            headers=keyed))
                    for path in ("/health", "/rigs/1", "/rigs/999999")]
        finally:
            connection.close()

    answers = asyncio.run(exchange())
    assert [status for status, _ in answers] == [200, 200, 404]
    assert json.loads(answers[1][1]) == server.client.get("/rigs/1").json()
    assert json.loads(answers[2][1])["error"]["type"] == "NotFoundError"


def test_closed_and_open_loops_count_answers_and_errors(server: LiveServer) -> None:
    health = request_bytes(server.base_url, "GET", "/health")
    unauthorised = request_bytes(server.base_url, "GET", "/rigs")  # no key: 401
    closed = asyncio.run(closed_loop(server.base_url, [health] * 20 + [unauthorised] * 5, 3))
    assert closed["n"] == 25 and closed["errors"] == 5
    assert closed["p50_ms"] > 0 and closed["throughput_rps"] > 0
    opened = asyncio.run(open_loop(server.base_url, [health] * 10, rate=50.0, duration=0.2))
    assert opened["sent"] == 10 and opened["errors"] == 0
    assert [json.loads(body)["status"] for body in opened["acknowledged"]] == ["ok"] * 10
    with pytest.raises(ValueError, match="requests needed"):
        asyncio.run(open_loop(server.base_url, [health], rate=50.0, duration=0.2))


def test_a_connection_the_server_closed_is_not_reused() -> None:
    """A server that closes each connection after its answer, without saying so (as the
    service closes one idle past its keep-alive): every request opens a new connection and
    none fails; sent on the closed one it met an empty answer (a ``ConnectionError``)."""
    async def run() -> tuple[dict[str, object], str]:
        async def answer_once(reader: asyncio.StreamReader,
                              writer: asyncio.StreamWriter) -> None:
            await reader.readuntil(b"\r\n\r\n")
            writer.write(b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nok")
            await writer.drain()
            writer.close()

        server = await asyncio.start_server(answer_once, "127.0.0.1", 0)
        base = f"http://127.0.0.1:{server.sockets[0].getsockname()[1]}"
        request = request_bytes(base, "GET", "/")
        async with server:
            opened = await open_loop(base, [request] * 3, rate=10.0, duration=0.3)
            stale = await Connection.open(base)
            await stale.exchange(request)
            await asyncio.sleep(0.1)
            assert not stale.reusable()
            try:
                await stale.exchange(request)
                reason = "answered"
            except ConnectionError as exc:
                reason = str(exc)
            stale.close()
        return opened, reason

    opened, reason = asyncio.run(run())
    assert opened["errors"] == 0 and opened["connections"] == 3
    assert reason == "the server closed the connection"


def test_an_idle_connection_expires_before_the_services_keep_alive(
        server: LiveServer, monkeypatch: pytest.MonkeyPatch) -> None:
    health = request_bytes(server.base_url, "GET", "/health")
    kept = asyncio.run(open_loop(server.base_url, [health] * 3, rate=10.0, duration=0.3))
    assert kept["errors"] == 0 and kept["connections"] == 1
    assert load_clients.KEEPALIVE_EXPIRY_S < 5.0  # uvicorn's timeout_keep_alive
    monkeypatch.setattr(load_clients, "KEEPALIVE_EXPIRY_S", 0.05)
    expired = asyncio.run(open_loop(server.base_url, [health] * 3, rate=10.0, duration=0.3))
    assert expired["errors"] == 0 and expired["connections"] == 3
