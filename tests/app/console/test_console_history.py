"""The history with 1,000 stored diagnoses: pagination and filters over real HTTP."""

from __future__ import annotations

import re
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta

import httpx
import pytest

from app.console.views import HISTORY_PAGE
from app.db.models import Diagnosis
from app.services.history import ComponentEstimate, add_diagnosis
from tests.app.conftest import simulated_record
from tests.app.console.conftest import login
from tests.app.live import LiveServer, live_server, store_settings

N = 1000
START = datetime(2025, 1, 1, 6, tzinfo=UTC)


@pytest.fixture(scope="module")
def full(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[LiveServer, httpx.Client]]:
    """A service whose rig 1 has N diagnoses, one every 6 hours from START."""
    with live_server(store_settings(tmp_path_factory.mktemp("full-store"))) as server:
        record = simulated_record(server, {"valve.cv": 40e-6}, measured_at=START.isoformat())
        answer = server.client.post("/diagnose", json={"record": record}, headers=server.auth)
        assert answer.status_code == 200, answer.text
        with server.session() as session:
            first = session.get(Diagnosis, answer.json()["diagnoses"][0]["id"])
            assert first is not None
            for i in range(1, N):
                at = START + timedelta(hours=6 * i)
                add_diagnosis(session, rig_id=1, measured_at=at,
                              record=dict(first.measurement.record) | {"measured_at": at.isoformat()},
                              result=first.result, component=first.component,
                              probability=first.probability,
                              estimates=[ComponentEstimate(e.component, e.probability,
                                                           e.clearance_m, e.slip_coefficient)
                                         for e in first.estimates],
                              rig_version_id=first.rig_version_id)
            session.commit()
        with httpx.Client(base_url=server.base_url, timeout=60.0) as client:
            yield server, login(server, client)


def _ids(html: str) -> list[int]:
    return [int(i) for i in re.findall(r'<td><a href="/console/diagnoses/(\d+)">', html)]


def test_the_history_is_paginated_newest_first(full: tuple[LiveServer, httpx.Client]) -> None:
    _, client = full
    first = client.get("/console/history?rig=1")
    assert f"({N} diagnoses)" in first.text
    pages = N // HISTORY_PAGE
    assert f"page 1 of {pages}" in first.text
    assert _ids(first.text) == list(range(N, N - HISTORY_PAGE, -1))  # id order = time order
    last = client.get(f"/console/history?rig=1&page={pages}")
    assert _ids(last.text) == list(range(HISTORY_PAGE, 0, -1))
    assert 'rel="next"' not in last.text and 'rel="prev"' in last.text
    seen = set()
    for page in range(1, pages + 1):
        seen |= set(_ids(client.get(f"/console/history?rig=1&page={page}").text))
    assert seen == set(range(1, N + 1))  # every diagnosis on exactly one page
    # a page past the last is the last ("page 99 of 3", empty: a maintenance planner's pass)
    beyond = client.get(f"/console/history?rig=1&page={pages + 97}")
    assert beyond.status_code == 200 and _ids(beyond.text) == _ids(last.text)
    assert f"page {pages} of {pages}" in beyond.text
    assert "<th>measured [UTC]</th>" in beyond.text


def test_the_history_filters_by_time_and_rig(full: tuple[LiveServer, httpx.Client]) -> None:
    _, client = full
    # four a day: 1 to 10 January inclusive of both ends' 06:00 → 9 days × 4 + 1 = 37
    html = client.get("/console/history?rig=1&since=2025-01-01T06:00:00Z"
                      "&until=2025-01-10T06:00:00Z").text
    assert "(37 diagnoses)" in html
    assert 'value="2025-01-01T06:00:00+00:00"' in html  # the filter is kept on the page
    # a rig the store does not have is a 404, as on the series and trends pages (it
    # showed an empty history: a console pass)
    unknown = client.get("/console/history?rig=2")
    assert unknown.status_code == 404 and "no rig with id 2" in unknown.text
    # the filter form sends blank fields for "any": the whole history
    assert f"({N} diagnoses)" in client.get("/console/history?rig=&since=&until=").text
    assert client.get("/console/trends?rig=1&since=&until=").status_code == 200
    # a date alone is the whole day, UTC, as the API reads it: `since` its start, `until`
    # its end (it was refused, then read as 00:00 for both, which missed the last day)
    dated = client.get("/console/history?rig=1&since=2025-01-01&until=2025-01-10")
    assert dated.status_code == 200 and 'value="2025-01-01T00:00:00+00:00"' in dated.text
    assert 'value="2025-01-10T23:59:59.999999+00:00"' in dated.text
    one_day = client.get("/console/history?rig=1&since=2025-01-02&until=2025-01-02").text
    assert "(4 diagnoses)" in one_day
    # a filter that cannot be read is named above the form, which keeps what was typed
    # (it replaced the whole page with an error page)
    bad = client.get("/console/history?rig=1&since=yesterday")
    assert bad.status_code == 422 and 'data-field="since"' in bad.text
    assert 'class="filters"' in bad.text and 'value="yesterday"' in bad.text
    assert "Nothing is listed until the filter is corrected." in bad.text
    # and claims no count: "(0 diagnoses)" read as an answer (a plant operator's pass)
    assert '<option value="1" selected>' in bad.text and "(0 diagnoses)" not in bad.text
    reversed_ = client.get("/console/history?since=2025-02-01T00:00:00Z"
                           "&until=2025-01-01T00:00:00Z")
    assert reversed_.status_code == 422 and 'data-field="since"' in reversed_.text
    assert 'value="2025-02-01T00:00:00Z"' in reversed_.text
    trends = client.get("/console/trends?rig=1&since=06:00 2025-01-01&until=")
    assert trends.status_code == 422 and 'data-field="since"' in trends.text
    assert 'value="06:00 2025-01-01"' in trends.text and "No estimates stored" not in trends.text
    # a time without its zone is UTC, as the form's label says (it was refused)
    zoneless = client.get("/console/history?rig=1&since=2025-01-02 00:00&until=2025-01-02 23:59")
    assert zoneless.status_code == 200 and "(4 diagnoses)" in zoneless.text
    assert 'value="2025-01-02T00:00:00+00:00"' in zoneless.text


def test_trends_and_a_diagnosis_page_of_the_full_rig_render(
        full: tuple[LiveServer, httpx.Client]) -> None:
    _, client = full
    trends = client.get("/console/trends?rig=1")
    assert trends.status_code == 200
    counts = [int(n) for n in re.findall(r'data-points="(\d+)"', trends.text)]
    assert counts and max(counts) >= N  # every diagnosis is a point of its trend
    assert client.get(f"/console/diagnoses/{N}").status_code == 200
    missing = client.get(f"/console/diagnoses/{N + 1}")
    assert missing.status_code == 404 and 'data-field="diagnosis_id"' in missing.text
