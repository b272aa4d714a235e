"""Read-back of the stored history: /measurements and /diagnoses (issue 14)."""

from __future__ import annotations

from typing import Any

import pytest

from tests.app.conftest import simulated_record
from tests.app.live import LiveServer

WORN_VALVE = {"valve.cv": 80e-6}


@pytest.fixture(scope="module")
def stored(server: LiveServer) -> dict[str, Any]:
    """Three stored diagnoses on rig 1 at known times, and one joint batch."""
    answers = []
    for day, overrides in (("01", WORN_VALVE), ("02", {}), ("03", WORN_VALVE)):
        record = simulated_record(server, overrides, measured_at=f"2026-03-{day}T10:00:00Z")
        response = server.client.post("/diagnose", json={"record": record})
        assert response.status_code == 200, response.text
        answers.append((record, response.json()["diagnoses"][0]))
    joint = [simulated_record(server, WORN_VALVE, load=load,
                              measured_at=f"2026-04-01T1{i}:00:00Z")
             for i, load in enumerate((2100.0, 4200.0))]
    response = server.client.post("/diagnose", json={"records": joint, "joint": True})
    assert response.status_code == 200, response.text
    return {"single": answers, "joint": response.json()["diagnoses"][0]}


def test_a_stored_diagnosis_reads_back_as_answered(server: LiveServer,
                                                   stored: dict[str, Any]) -> None:
    record, answer = stored["single"][0]
    got = server.client.get(f"/diagnoses/{answer['id']}")
    assert got.status_code == 200
    body = got.json()
    assert body["result"] == answer["result"]
    assert body["component"] == answer["component"]
    assert body["probability"] == pytest.approx(answer["probability"])
    assert body["measurement_id"] == answer["measurement_ids"][0]
    assert body["rig_id"] == 1 and body["rig_version"] == answer["rig_version"]
    assert {e["component"] for e in body["estimates"]} == {
        e["component"] for e in answer["estimates"]}
    # one shape: each estimate read back carries the answer's fields and values
    read = {e["component"]: e for e in body["estimates"]}
    for sent in answer["estimates"]:
        assert {k: read[sent["component"]][k] for k in sent} == pytest.approx(sent)
    measurement = server.client.get(f"/measurements/{body['measurement_id']}").json()
    assert measurement["diagnosis_ids"] == [answer["id"]]
    assert measurement["record"]["p1"] == {"value": record["p1"]}
    assert measurement["measured_at"].startswith("2026-03-01T10:00:00")


def test_lists_filter_by_rig_and_time_newest_first(server: LiveServer,
                                                   stored: dict[str, Any]) -> None:
    ids = [answer["id"] for _, answer in stored["single"]]
    march = server.client.get("/diagnoses", params={
        "rig_id": 1, "since": "2026-03-01T00:00:00Z", "until": "2026-03-31T00:00:00Z"}).json()
    assert [d["id"] for d in march["items"]] == ids[::-1] and march["total"] == 3
    second = server.client.get("/diagnoses", params={
        "since": "2026-03-02T00:00:00Z", "until": "2026-03-02T23:59:59Z"}).json()
    assert [d["id"] for d in second["items"]] == [ids[1]]
    paged = server.client.get("/diagnoses", params={"limit": 1, "offset": 1,
                                                    "until": "2026-03-31T00:00:00Z"}).json()
    assert [d["id"] for d in paged["items"]] == [ids[1]] and paged["total"] == 3
    assert server.client.get("/diagnoses", params={"rig_id": 999}).json()["total"] == 0
    april = server.client.get("/measurements", params={"since": "2026-04-01T00:00:00Z"}).json()
    assert april["total"] == 2  # both records of the joint batch are stored
    # each record of the joint batch reads back the diagnosis it took part in (the one the
    # result is not kept with read none before revision 0008)
    assert [m["diagnosis_ids"] for m in april["items"]] == [[stored["joint"]["id"]]] * 2
    joint = server.client.get(f"/diagnoses/{stored['joint']['id']}").json()
    assert joint["measurement_ids"] == sorted(stored["joint"]["measurement_ids"])
    assert joint["measurement_id"] in joint["measurement_ids"]
    single = server.client.get(f"/diagnoses/{stored['single'][0][1]['id']}").json()
    assert single["measurement_ids"] == [single["measurement_id"]]
    # read back as POST /diagnose answered it: its top name, explained, and its time
    posted = stored["single"][0][1]
    assert (single["top"], single["explained"]) == (posted["top"], posted["explained"])
    assert single["measured_at"] == posted["measured_at"]


def test_the_component_filter_finds_the_pairs_that_blame_it(server: LiveServer) -> None:
    """``component=valve`` once matched only a top of exactly "valve": a spool and pump worn
    together ("valve+pump") was left out of the valve's list."""
    window = {"since": "2026-06-01T00:00:00Z", "until": "2026-06-30T00:00:00Z"}
    posted = {}
    for day, overrides in (("01", {"valve.cv": 80e-6, "pump.Rlp": 6e11 / 12}),
                           ("02", WORN_VALVE), ("03", {})):
        record = simulated_record(server, overrides, measured_at=f"2026-06-{day}T10:00:00Z")
        answer = server.client.post("/diagnose", json={"record": record}).json()["diagnoses"][0]
        posted[answer["id"]] = answer["component"]
    assert sorted(posted.values()) == ["healthy", "valve", "valve+pump"]

    def listed(component: str) -> set[int]:
        got = server.client.get("/diagnoses", params=window | {"component": component})
        assert got.status_code == 200, got.text
        return {d["id"] for d in got.json()["items"]}

    for component in ("valve", "pump", "valve+pump", "healthy", "cylinder"):
        expected = {i for i, c in posted.items()
                    if c == component or component in c.split("+")}
        assert listed(component) == expected, component
    # a name outside the library is refused, not answered with an empty page
    bad = server.client.get("/diagnoses", params={"component": "spool"})
    assert bad.status_code == 422 and bad.json()["error"]["field"] == "component"


def test_read_back_errors(server: LiveServer, stored: dict[str, Any]) -> None:
    assert server.client.get("/diagnoses/999999").status_code == 404
    assert server.client.get("/measurements/999999").json()["error"]["type"] == "NotFoundError"
    bad = server.client.get("/measurements", params={"since": "2026-05-01T00:00:00Z",
                                                     "until": "2026-04-01T00:00:00Z"})
    assert bad.status_code == 422 and bad.json()["error"]["field"] == "until"
    naive = server.client.get("/diagnoses", params={"since": "2026-05-01T00:00:00"})
    assert naive.status_code == 422 and naive.json()["error"]["field"] == "since"
    # an offset's "+" written into the URL as it is arrives as a space: said so
    plus = server.client.get("/diagnoses?since=2026-05-01T14:00:00+05:00")
    assert plus.status_code == 422 and plus.json()["error"]["field"] == "since"
    assert "%2B" in plus.json()["error"]["message"]
    encoded = server.client.get("/diagnoses?since=2026-05-01T14:00:00%2B05:00")
    assert encoded.status_code == 200
    assert server.anon.get("/diagnoses").status_code == 401
    assert server.anon.get(f"/measurements/{stored['single'][0][1]['measurement_ids'][0]}"
                           ).status_code == 401


def test_the_component_filter_names_what_the_fault_library_can_blame() -> None:
    """The filter's closed list is written out for the OpenAPI document; it must be the
    fault library's components and pairs, with healthy and unexplained."""
    from typing import get_args

    from app.schemas.history import BlamedComponent
    from diagnostics.hypotheses import HYPOTHESES

    blamed = {"+".join(h.components) or "healthy" for h in HYPOTHESES} | {"unexplained"}
    assert set(get_args(BlamedComponent)) == blamed


def test_a_cursor_reads_everything_stored_once_while_late_logs_arrive(
        server: LiveServer, stored: dict[str, Any]) -> None:
    # offset paging, newest measurement first, shifts under inserts (an older late log
    # lands ahead of the cursor): an exporter got 8 duplicates and missed 8 of 42 rows
    def page(after: int, limit: int = 2) -> dict[str, Any]:
        got = server.client.get("/diagnoses", params={"after_id": after, "limit": limit})
        assert got.status_code == 200, got.text
        return got.json()

    everything = server.client.get("/diagnoses", params={"limit": 500}).json()["items"]
    seen, cursor = [], 0
    first = page(cursor)
    seen += [d["id"] for d in first["items"]]
    cursor = first["next_after_id"]
    assert cursor == seen[-1]
    # a late log, measured long before everything stored, arrives between two pages
    late = simulated_record(server, WORN_VALVE, measured_at="2025-01-01T00:00:00Z")
    new = server.client.post("/diagnose", json={"record": late}).json()["diagnoses"][0]
    while True:
        body = page(cursor)
        if not body["items"]:
            assert body["next_after_id"] == cursor   # polling again later starts here
            break
        seen += [d["id"] for d in body["items"]]
        cursor = body["next_after_id"]
    assert seen == sorted(seen) and len(seen) == len(set(seen))
    assert set(seen) == {d["id"] for d in everything} | {new["id"]}
    measurements = server.client.get("/measurements", params={
        "after_id": new["measurement_ids"][0] - 1}).json()
    assert [m["id"] for m in measurements["items"]] == new["measurement_ids"]
    # offset paging reads no cursor back; a cursor goes without an offset
    assert server.client.get("/diagnoses").json()["next_after_id"] is None
    both = server.client.get("/diagnoses", params={"after_id": 0, "offset": 5})
    assert both.status_code == 422 and both.json()["error"]["field"] == "offset"


def test_a_wrong_record_is_deleted_with_every_diagnosis_made_from_it(
        server: LiveServer) -> None:
    """A record entered wrongly could not be removed, and a corrected one was stored beside
    it (a maintenance planner's pass): DELETE /measurements/{id} (admin) removes it, its
    diagnosis and the joint diagnosis it took part in; the joint's other record stays, the
    trend forgets the estimates, and the corrected record at the same time is then stored."""
    from app.db.models import Diagnosis, DiagnosisEstimate, Measurement
    from app.security import Scope
    from app.services.keys import create_api_key
    from tests.app.conftest import new_rig

    rig_id = int(new_rig(server, "wrong-record-rig")["id"])
    wrong = simulated_record(server, {"valve.cv": 80e-6}, rig_id=rig_id,
                             measured_at="2026-05-01T10:00:00Z")
    single = server.client.post("/diagnose", json={"record": wrong}).json()["diagnoses"][0]
    other = simulated_record(server, {}, rig_id=rig_id, load=4200.0,
                             measured_at="2026-05-01T11:00:00Z")
    joint = server.client.post("/diagnose", json={"records": [wrong | {
        "measured_at": "2026-05-01T10:30:00Z"}, other], "joint": True}).json()["diagnoses"][0]
    (measurement_id,) = single["measurement_ids"]
    kept = joint["measurement_ids"][1]
    with server.session() as session:
        before = (session.query(Diagnosis).count(), session.query(DiagnosisEstimate).count())
        _, write_key = create_api_key(session, "writer", Scope.WRITE)
    refused = server.anon.delete(f"/measurements/{measurement_id}",
                                 headers={"X-API-Key": write_key})
    assert refused.status_code == 403
    # the joint diagnosis was made from the wrong record's twin at 10:30: delete that one
    twin = joint["measurement_ids"][0]
    for gone in (measurement_id, twin):
        response = server.client.delete(f"/measurements/{gone}", headers=server.auth)
        assert response.status_code == 204, response.text
        assert server.client.get(f"/measurements/{gone}").status_code == 404
    assert server.client.get(f"/diagnoses/{single['id']}").status_code == 404
    assert server.client.get(f"/diagnoses/{joint['id']}").status_code == 404
    # the joint visit's other record goes too: kept without a diagnosis, a re-post of the
    # visit was stored beside it (a check of this fix)
    assert server.client.get(f"/measurements/{kept}").status_code == 404
    with server.session() as session:
        assert session.get(Measurement, kept) is None
        after = (session.query(Diagnosis).count(), session.query(DiagnosisEstimate).count())
    assert after[0] == before[0] - 2 and after[1] < before[1]
    listed = server.client.get("/diagnoses", params={"rig_id": rig_id}).json()
    assert listed["total"] == 0
    again = server.client.delete(f"/measurements/{measurement_id}", headers=server.auth)
    assert again.status_code == 404
    assert again.json()["error"]["field"] == "measurement_id"     # every 404 names its field
    corrected = simulated_record(server, {}, rig_id=rig_id, measured_at="2026-05-01T10:00:00Z")
    stored = server.client.post("/diagnose", json={"record": corrected})
    assert stored.status_code == 200, stored.text


def test_a_compact_page_leaves_out_the_predictions(server: LiveServer,
                                                  stored: dict[str, Any]) -> None:
    """500 full history items were 7 MB (a planner's pass): `compact` drops each
    hypothesis's predicted readings, as /diagnose's compact answer does (here 23 % of the
    page)."""
    full = server.client.get("/diagnoses", params={"rig_id": 1, "limit": 3})
    compact = server.client.get("/diagnoses", params={"rig_id": 1, "limit": 3,
                                                      "compact": True})
    assert compact.status_code == 200
    assert len(compact.content) < 0.85 * len(full.content)
    for a, b in zip(full.json()["items"], compact.json()["items"], strict=True):
        assert all("predicted" in h for h in a["result"]["hypotheses"])
        assert not any("predicted" in h for h in b["result"]["hypotheses"])
        assert [h["probability"] for h in a["result"]["hypotheses"]] == \
            [h["probability"] for h in b["result"]["hypotheses"]]
        assert a["estimates"] == b["estimates"]


def test_a_window_given_as_dates_takes_whole_days(server: LiveServer,
                                                  stored: dict[str, Any]) -> None:
    """The console took `since=2026-03-02`, the API refused it (a planner's pass): a date
    alone is the start of that day for `since`, its end for `until`, in UTC."""
    by_day = server.client.get("/diagnoses", params={"rig_id": 1, "since": "2026-03-02",
                                                     "until": "2026-03-03"})
    assert by_day.status_code == 200, by_day.text
    days = sorted(d["measured_at"][:10] for d in by_day.json()["items"])
    assert days == ["2026-03-02", "2026-03-03"]
    trend = server.client.get("/rigs/1/trends", params={"since": "2026-03-02",
                                                        "until": "2026-03-03"})
    assert trend.status_code == 200
    assert server.client.get("/diagnoses", params={"since": "2026-3-2"}).status_code == 422
