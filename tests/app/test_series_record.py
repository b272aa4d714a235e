"""GET /series/{id}/record: a measured cycle, imported as a user has it, read as the record
POST /diagnose takes, and diagnosed; bad reads are 422s naming the field, nothing stored."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from sim.rigs import load_rig_document
from tests.app.live import LiveServer

ZEMA = Path(__file__).resolve().parents[2] / "sim" / "rigs" / "zema.yaml"


def _simulated_cycle(server: LiveServer, fault: str, load: float) -> bytes:
    """The cycle /simulate exports as CSV (its header states the condition)."""
    r = server.client.post("/simulate", json={
        "rig_id": 1, "fault": fault, "condition": {"load": load, "oil_temperature": 40.0},
        "timeseries": "csv", "sample_rate": 1000.0}, headers=server.auth)
    assert r.status_code == 200, r.text
    return r.content


def _import(server: LiveServer, content: bytes, rig: int = 1, name: str = "cycle") -> int:
    r = server.client.post(f"/rigs/{rig}/series", data={"name": name},
                           files={"file": ("cycle.csv", content, "text/csv")},
                           headers=server.auth)
    assert r.status_code == 201, r.text
    return int(r.json()["items"][0]["id"])


@pytest.fixture(scope="module")
def worn_spool_series(server: LiveServer) -> int:
    return _import(server, _simulated_cycle(server, "worn_spool", 4200.0))


def test_a_stored_cycle_is_read_as_a_record_and_diagnosed(server: LiveServer,
                                                          worn_spool_series: int) -> None:
    r = server.client.get(f"/series/{worn_spool_series}/record")
    assert r.status_code == 200, r.text
    read = r.json()
    record = read["record"]
    assert record["rig_id"] == 1 and record["rig_version"] == read["rig_version"] == 1
    assert record["condition"] == {"load_force": 4200.0, "oil_temperature": 40.0}
    assert set(record) >= {"pump_pressure", "p1", "p2", "flow_B", "flow_C",
                           "speed_work", "speed_return"}
    assert "pump_flow" not in record  # meter B again, were it built from B + relief
    working, returning = read["phases"]
    assert working["completed"] and returning["completed"] and read["notes"] == []
    assert 0.0 < working["window_start"] < working["window_end"] < returning["window_start"]
    assert record["p1"] == working["averages"]["P1"]
    # mass balance of the working phase's meters: B in = C out + the leaks upstream of C
    assert record["flow_B"] > record["flow_C"] > 0.0
    before = server.row_counts()["diagnoses"]
    d = server.client.post("/diagnose", json={"record": record}, headers=server.auth)
    assert d.status_code == 200, d.text
    [answer] = d.json()["diagnoses"]
    assert answer["top"] == "valve" and answer["id"] is not None
    assert server.row_counts()["diagnoses"] == before + 1
    # the series has no start, so the record no time: posted again as it is, it was stored
    # again at the request's time (a cycle counted four times in a trend, a new engineer's
    # pass); it is refused naming the stored diagnosis, and store false still answers
    again = server.client.post("/diagnose", json={"record": record}, headers=server.auth)
    assert again.status_code == 409, again.text
    error = again.json()["error"]
    assert error["field"] == "series_id" and f"diagnosis {answer['id']}" in error["message"]
    assert server.row_counts()["diagnoses"] == before + 1
    dry = server.client.post("/diagnose", json={"record": record, "store": False},
                             headers=server.auth)
    assert dry.status_code == 200 and dry.json()["diagnoses"][0]["top"] == "valve"
    # the condition given in the query overrides the series'
    hot = server.client.get(f"/series/{worn_spool_series}/record",
                            params={"oil_temperature": 45.0}).json()
    assert hot["record"]["condition"]["oil_temperature"] == 45.0


@pytest.mark.parametrize(("params", "status", "field"), [
    ({"rig_version": 9}, 404, "rig_version"),
    ({"temperature": 40}, 422, "temperature"),
    ({"oil_temperature": "warm"}, 422, "oil_temperature"),
    ({"oil_temperature": 400.0}, 422, "condition.oil_temperature"),
    ({"back_pressure": 1.0e6}, 422, "condition.back_pressure"),
])
def test_bad_reads_name_the_field(server: LiveServer, worn_spool_series: int,
                                  params: dict[str, Any], status: int, field: str) -> None:
    before = server.row_counts()
    r = server.client.get(f"/series/{worn_spool_series}/record", params=params)
    assert r.status_code == status, r.text
    assert r.json()["error"]["field"] == field
    assert server.row_counts() == before


def test_what_is_no_cycle_is_refused(server: LiveServer) -> None:
    assert server.client.get("/series/999999/record").status_code == 404
    flat = _import(server, b"t [s],P_pump [bar]\n0,10\n1,11\n")
    r = server.client.get(f"/series/{flat}/record")
    assert r.status_code == 422 and r.json()["error"]["field"] == "x", r.text
    zema = server.client.post("/rigs", json={"document": load_rig_document(ZEMA)},
                              headers=server.auth)
    assert zema.status_code == 201, zema.text
    pumped = _import(server, b"t [s],phase,P_pump [bar]\n0,working,10\n1,working,11\n",
                     rig=int(zema.json()["id"]))
    r = server.client.get(f"/series/{pumped}/record")
    assert r.status_code == 422 and r.json()["error"]["type"] == "CircuitError", r.text


def test_a_cycle_stored_with_its_clock_time_is_diagnosed_at_that_time(
        server: LiveServer) -> None:
    """The import's start (here the file header's, then the form's) puts each record at its
    first sample's time; the record read from the series carries it, and the history stores
    the diagnosis there, not at the time of the request."""
    # a cycle no other test stores (the same samples without a start are the fixture's)
    exported = _simulated_cycle(server, "worn_spool", 4150.0)
    headed = b'# started_at = "2026-11-20T08:00:00+01:00"\n' + exported
    r = server.client.post("/rigs/1/series", data={"name": "visit"},
                           files={"file": ("cycle.csv", headed, "text/csv")},
                           headers=server.auth)
    assert r.status_code == 201, r.text
    [item] = r.json()["items"]
    assert item["measured_at"] == "2026-11-20T07:00:00Z"  # t starts at 0 in the export
    read = server.client.get(f"/series/{item['id']}/record").json()
    assert read["record"]["measured_at"] == "2026-11-20T07:00:00Z"
    d = server.client.post("/diagnose", json={"record": read["record"]}, headers=server.auth)
    assert d.status_code == 200, d.text
    [answer] = d.json()["diagnoses"]
    stored = server.client.get(f"/measurements/{answer['measurement_ids'][0]}").json()
    assert stored["measured_at"] == "2026-11-20T07:00:00Z"
    assert stored["record"]["series_id"] == read["record"]["series_id"] == item["id"]
    # the form's start wins over the header's; a record's time is its first sample's
    two = (b"t [s],record,x [m]\n" + b"".join(
        f"{t},{rec},{0.1 * t}\n".encode() for rec, ts in (("a", (0, 1)), ("b", (90.5, 91)))
        for t in ts))
    r = server.client.post("/rigs/1/series",
                           data={"name": "two", "started_at": "2026-11-21T10:00:00Z"},
                           files={"file": ("two.csv", b'# started_at = "2020-01-01T00:00:00Z"\n'
                                           + two, "text/csv")}, headers=server.auth)
    assert r.status_code == 201, r.text
    assert [i["measured_at"] for i in r.json()["items"]] == [
        "2026-11-21T10:00:00Z", "2026-11-21T10:01:30.500000Z"]
    # the same cycle again, under another name and file name and without a start: the
    # same samples are refused, naming the series that holds them
    again = server.client.post("/rigs/1/series", data={"name": "plain"},
                               files={"file": ("copy.csv", exported, "text/csv")},
                               headers=server.auth)
    assert again.status_code == 409 and "stored already" in again.text
    assert re.search(rf"samples \(series [\d, ]*\b{item['id']}\b", again.json()["error"][
        "message"]), again.text
    # without a start a series has no time, and neither has the record read from it
    shorter = exported[:exported.rstrip(b"\n").rfind(b"\n") + 1]   # one sample less
    plain = _import(server, shorter, name="plain")
    assert server.client.get(f"/series/{plain}").json()["measured_at"] is None
    assert "measured_at" not in server.client.get(f"/series/{plain}/record").json()["record"]


@pytest.mark.parametrize(("header", "form", "field"), [
    (b'# started_at = "2026-11-20T08:00:00"\n', {}, "file.started_at"),
    (b'# started_at = "yesterday"\n', {}, "file.started_at"),
    (b"", {"started_at": "2026-11-20T08:00:00"}, "started_at"),
    (b"", {"started_at": "1763625600"}, "started_at"),
])
def test_a_start_without_its_zone_is_refused_and_nothing_stored(
        server: LiveServer, header: bytes, form: dict[str, str], field: str) -> None:
    before = server.row_counts()
    r = server.client.post("/rigs/1/series", data={"name": "bad-time"} | form,
                           files={"file": ("c.csv", header + b"t [s],x [m]\n0,0\n1,0.1\n",
                                           "text/csv")}, headers=server.auth)
    assert r.status_code == 422, r.text
    assert r.json()["error"]["field"] == field
    assert server.row_counts() == before


def test_a_record_names_a_series_of_its_own_rig(server: LiveServer,
                                                worn_spool_series: int) -> None:
    """``series_id`` (put there by GET /series/{id}/record) is kept with the stored record;
    a series of another rig is a 422 and an unknown one a 404, both naming the field, with
    nothing stored."""
    record = server.client.get(f"/series/{worn_spool_series}/record").json()["record"]
    zema = server.client.post("/rigs", json={"document": load_rig_document(ZEMA) | {
        "name": "zema-provenance"}}, headers=server.auth)
    assert zema.status_code == 201, zema.text
    other = _import(server, b"t [s],P_pump [bar]\n0,10\n1,11\n", rig=int(zema.json()["id"]))
    before = server.row_counts()
    for series, status in ((other, 422), (999999, 404)):
        for body in ({"record": record | {"series_id": series}},
                     {"records": [record, record | {"series_id": series}]}):
            r = server.client.post("/diagnose", json=body, headers=server.auth)
            assert r.status_code == status, r.text
            path = "record" if "record" in body else "records[1]"
            assert r.json()["error"]["field"] == f"{path}.series_id"
    assert server.row_counts() == before
