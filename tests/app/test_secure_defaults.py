"""Secure defaults (issue 14 item 5): loopback bind outside the container, CORS closed on
every kind of operation, JSON logs and the access line on."""

from __future__ import annotations

import pytest

from app.settings import Settings
from tests.app.live import LiveServer


def test_the_default_bind_is_loopback(monkeypatch: pytest.MonkeyPatch) -> None:
    for variable in ("HYDRODIAG_HOST", "HYDRODIAG_LOG_FORMAT", "HYDRODIAG_ACCESS_LOG"):
        monkeypatch.delenv(variable, raising=False)
    settings = Settings()
    assert settings.host == "127.0.0.1"
    assert settings.log_format == "json" and settings.access_log


@pytest.mark.parametrize(("method", "path"), [("POST", "/diagnose"), ("DELETE", "/rigs/999999"),
                                              ("POST", "/rigs"), ("GET", "/diagnoses")])
def test_no_origin_is_allowed_to_call_across_sites(server: LiveServer, method: str,
                                                    path: str) -> None:
    origin = "http://attacker.example"
    preflight = server.anon.options(path, headers={
        "Origin": origin, "Access-Control-Request-Method": method,
        "Access-Control-Request-Headers": "x-api-key, content-type"})
    assert not any(h.startswith("access-control-allow") for h in preflight.headers)
    before = server.row_counts()
    answer = server.client.request(method, path, headers={"Origin": origin},
                                   json={} if method == "POST" else None)
    assert not any(h.startswith("access-control-allow") for h in answer.headers)
    assert server.row_counts() == before
