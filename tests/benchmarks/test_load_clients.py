"""The load benchmark's raw HTTP client against a real server: requests built as bytes are
answered as an HTTP client library would see them, bodies intact, connections reused."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Iterator
from pathlib import Path

import pytest

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
