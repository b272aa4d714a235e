"""The service log over real HTTP: one JSON line per request with its id, ids echoed and in
error bodies, and no key, secret or body in the log."""

from __future__ import annotations

import io
import json
import logging
import os
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from app.db.models import ApiKey
from app.logs import ACCESS_LOGGER, MAX_REQUEST_ID_LENGTH, JsonFormatter
from tests.app.conftest import first_api_key
from tests.app.live import LiveServer, live_server, store_settings

SECRET_IN_BODY = "body-secret-7f3e9a"
SECRET_IN_HEADER = "hd_0123456789ab_headersecret5c1d"
GENERATED = re.compile(r"[0-9a-f]{32}")


@pytest.fixture(scope="module")
def logged(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[LiveServer, io.StringIO]]:
    """A server whose ``hydrodiag`` log is written, as JSON, into a buffer."""
    buffer = io.StringIO()
    handler = logging.StreamHandler(buffer)
    handler.setFormatter(JsonFormatter())
    logger = logging.getLogger("hydrodiag")
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        settings = store_settings(tmp_path_factory.mktemp("logs"), max_body_bytes=4096)
        with live_server(settings) as live:
            yield live, buffer
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def _access_lines(buffer: io.StringIO) -> list[dict[str, Any]]:
    lines = [json.loads(line) for line in buffer.getvalue().splitlines() if line.strip()]
    return [line for line in lines if line["logger"] == ACCESS_LOGGER]


def _line_of(buffer: io.StringIO, request_id: str) -> dict[str, Any]:
    for _ in range(50):  # the line is written when the response has been sent
        found = [line for line in _access_lines(buffer) if line["request_id"] == request_id]
        if found:
            assert len(found) == 1
            return found[0]
        time.sleep(0.02)
    raise AssertionError(f"no access line for {request_id}")


def test_a_request_id_is_echoed_logged_and_in_error_bodies(
        logged: tuple[LiveServer, io.StringIO]) -> None:
    server, buffer = logged
    ok = server.client.get("/rigs/1", headers={"X-Request-ID": "plant-7:run.42"})
    assert ok.status_code == 200 and ok.headers["X-Request-ID"] == "plant-7:run.42"
    line = _line_of(buffer, "plant-7:run.42")
    with server.session() as session:
        key_id = session.query(ApiKey).filter(ApiKey.prefix == server.key.split("_")[1]).one().id
    assert line["method"] == "GET" and line["route"] == "/rigs/{rig_id}"
    assert line["status"] == 200 and line["key_id"] == key_id and line["duration_ms"] > 0
    assert line["level"] == "info"
    missing = server.client.get("/rigs/999", headers={"X-Request-ID": "lookup-1"})
    assert missing.status_code == 404
    assert missing.json()["error"]["request_id"] == "lookup-1"
    assert _line_of(buffer, "lookup-1")["status"] == 404


@pytest.mark.parametrize("offered", ["has space", "x" * (MAX_REQUEST_ID_LENGTH + 1), "é",
                                     "a;b", ""])
def test_a_malformed_request_id_is_replaced(logged: tuple[LiveServer, io.StringIO],
                                            offered: str) -> None:
    server, buffer = logged
    response = server.client.get("/rigs", headers={"X-Request-ID": offered.encode("utf-8")})
    assert response.status_code == 200
    request_id = response.headers["X-Request-ID"]
    assert GENERATED.fullmatch(request_id) and request_id != offered
    _line_of(buffer, request_id)
    if offered:
        assert offered not in buffer.getvalue()


def test_every_error_kind_carries_the_request_id(logged: tuple[LiveServer, io.StringIO]) -> None:
    server, buffer = logged
    cases = {
        "unauthorised": (server.anon.get("/rigs", headers={"X-Request-ID": "unauthorised"}), 401),
        "invalid": (server.client.post("/simulate", json={"rig_id": 1, "bogus": 1},
                                       headers={"X-Request-ID": "invalid"}), 422),
        "too-large": (server.client.post("/rigs", content=b"x" * 5000, headers={
            "X-Request-ID": "too-large", "Content-Type": "application/json"}), 413),
        "no-route": (server.client.get("/nowhere", headers={"X-Request-ID": "no-route"}), 404),
    }
    for request_id, (response, status) in cases.items():
        assert response.status_code == status, (request_id, response.text)
        assert response.json()["error"]["request_id"] == request_id
        assert response.headers["X-Request-ID"] == request_id
        line = _line_of(buffer, request_id)
        assert line["status"] == status
    assert _line_of(buffer, "no-route")["route"] == "<unmatched>"
    assert _line_of(buffer, "unauthorised")["key_id"] is None


def test_no_key_secret_or_body_reaches_the_log(logged: tuple[LiveServer, io.StringIO]) -> None:
    server, buffer = logged
    document = {"name": SECRET_IN_BODY, "bogus": SECRET_IN_BODY}
    refused = server.client.post(f"/rigs?note={SECRET_IN_BODY}", json={"document": document})
    assert refused.status_code == 422
    assert server.anon.get("/rigs", headers={"X-API-Key": SECRET_IN_HEADER}).status_code == 401
    assert server.client.get("/rigs", headers={"Authorization": f"Bearer {SECRET_IN_HEADER}"}
                             ).status_code == 200
    _line_of(buffer, server.client.get("/health").headers["X-Request-ID"])
    text = buffer.getvalue()
    assert _access_lines(buffer)
    for secret in (SECRET_IN_BODY, SECRET_IN_HEADER, server.key, server.key.split("_")[2]):
        assert secret not in text


def test_serve_writes_json_lines_without_secrets(tmp_path: Path) -> None:
    """``hydrodiag serve`` in a subprocess: its standard error, as an operator sees it."""
    from tests.app.test_cli import _free_port, _wait_healthy, _wait_ready

    port = _free_port()
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(tmp_path), "HYDRODIAG_LOG_FORMAT": "json"}
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    base_url = f"http://127.0.0.1:{port}"
    try:
        _wait_healthy(process, base_url)
        _wait_ready(base_url)
        secret = {"X-API-Key": SECRET_IN_HEADER, "X-Request-ID": "subprocess-1"}
        assert httpx.post(f"{base_url}/simulate", headers=secret,
                          json={"rig_id": 1, "note": SECRET_IN_BODY}).status_code == 401
    finally:
        process.terminate()
        stdout, stderr = process.communicate(timeout=30)
    key = first_api_key(tmp_path, stdout)
    records = [json.loads(line) for line in stderr.splitlines() if line.startswith("{")]
    access = [r for r in records if r["logger"] == ACCESS_LOGGER]
    assert any(r["request_id"] == "subprocess-1" and r["status"] == 401
               and r["route"] == "/simulate" for r in access)
    assert all({"time", "level", "method", "route", "status", "duration_ms", "request_id",
                "key_id"} <= set(r) for r in access)
    for secret_text in (SECRET_IN_BODY, SECRET_IN_HEADER, key):
        assert secret_text not in stderr


def test_the_service_log_follows_standard_error_when_it_is_replaced(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A server thread logging after the standard error it started with was closed (a
    test's captured output) printed "--- Logging error --- ... I/O operation on closed
    file" with a traceback into CI's log; the line now goes to standard error as it is."""
    from app.logs import configure_logging

    logger = logging.getLogger("hydrodiag")
    saved = (list(logger.handlers), logger.level, logger.propagate)
    first, second = io.StringIO(), io.StringIO()
    try:
        monkeypatch.setattr(sys, "stderr", first)
        configure_logging("text", "info")
        logging.getLogger("hydrodiag.test").info("to the first")
        first.close()
        monkeypatch.setattr(sys, "stderr", second)
        logging.getLogger("hydrodiag.test").info("to the second")
        assert "to the second" in second.getvalue()
        assert "Logging error" not in second.getvalue()
    finally:
        logger.handlers[:] = saved[0]
        logger.setLevel(saved[1])
        logger.propagate = saved[2]


def test_a_client_gone_before_its_answer_is_logged_and_counted_as_499(
        caplog: pytest.LogCaptureFixture) -> None:
    """A body cut off as too slow (app.nodelay) was logged and counted as the 422 the app
    then tried to send, with no key (a verification pass): a client that went away while
    its body was read is 499, nginx's "client closed request"; one that stayed gets the
    app's status."""
    import asyncio

    from app.logs import ACCESS_LOGGER, CLIENT_CLOSED, RequestLogMiddleware
    from app.metrics import HttpMetrics, MetricsMiddleware

    async def app(scope: Any, receive: Any, send: Any) -> None:   # reads, then refuses
        while (await receive()).get("more_body"):
            pass
        await send({"type": "http.response.start", "status": 422, "headers": []})
        await send({"type": "http.response.body", "body": b"{}"})

    metrics = HttpMetrics()
    stack = RequestLogMiddleware(MetricsMiddleware(app, metrics))

    def run(messages: list[dict[str, Any]]) -> None:
        queue = list(messages)

        async def receive() -> dict[str, Any]:
            return queue.pop(0)

        async def send(message: dict[str, Any]) -> None:
            pass

        scope = {"type": "http", "method": "POST", "path": "/diagnose", "headers": [],
                 "query_string": b""}
        asyncio.run(stack(scope, receive, send))

    with caplog.at_level("INFO", logger=ACCESS_LOGGER):
        run([{"type": "http.request", "body": b"{", "more_body": True},
             {"type": "http.disconnect"}])
        run([{"type": "http.request", "body": b"{}", "more_body": False}])
    statuses = [r.status for r in caplog.records if r.name == ACCESS_LOGGER]  # type: ignore[attr-defined]
    assert statuses == [CLIENT_CLOSED, 422]
    counted = {s.labels["status"]: s.value for m in metrics.registry.collect()
               for s in m.samples if s.name.endswith("requests_total")}
    assert counted == {"499": 1.0, "422": 1.0}
