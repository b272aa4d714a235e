"""GET /series/{id}/record: a measured cycle, imported as a user has it, read as the record
POST /diagnose takes, and diagnosed; bad reads are 422s naming the field, nothing stored."""

from __future__ import annotations

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


def _import(server: LiveServer, content: bytes, rig: int = 1) -> int:
    r = server.client.post(f"/rigs/{rig}/series", data={"name": "cycle"},
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
    assert set(record) >= {"pump_pressure", "p1", "p2", "flow_B", "flow_C", "pump_flow",
                           "speed_work", "speed_return"}
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
