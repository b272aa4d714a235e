"""The console honours key scopes: a read key browses but cannot store a diagnosis."""

from __future__ import annotations

import json
import re

import httpx

from app.security import Scope
from app.services.keys import create_api_key
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer


def test_a_read_key_browses_but_cannot_store_a_diagnosis(console_server: LiveServer) -> None:
    with console_server.session() as session:
        _, plaintext = create_api_key(session, "console-read", Scope.READ)
    record = simulated_record(console_server)
    before = console_server.row_counts()
    with httpx.Client(base_url=console_server.base_url) as client:
        assert client.post("/console/login",
                           data={"api_key": plaintext, "next": ""}).status_code == 303
        assert client.get("/console/history").status_code == 200
        refused = client.post("/console/diagnose", data={"document": json.dumps(record)})
    assert refused.status_code == 403
    match = re.search(r'data-field="api_key">(.*?)</div>', refused.text, re.S)
    assert match is not None and "scope &#39;write&#39;" in match.group(1)
    assert console_server.row_counts() == before
