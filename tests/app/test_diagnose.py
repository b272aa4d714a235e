"""POST /diagnose through HTTP: ranking of simulated faults, storage, batches, errors."""

from __future__ import annotations

from typing import Any

import pytest

from tests.app.conftest import new_rig, simulated_record
from tests.app.live import LiveServer

WORN_VALVE = {"valve.cv": 60e-6}


def test_a_worn_valve_record_ranks_the_valve_first_and_is_stored(server: LiveServer) -> None:
    record = simulated_record(server, WORN_VALVE, measured_at="2026-03-01T08:00:00Z")
    before = server.row_counts()
    response = server.client.post("/diagnose", json={"record": record}, headers=server.auth)
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["mode"] == "single" and body["stored"] is True
    (diagnosis,) = body["diagnoses"]
    assert diagnosis["top"] == "valve" and diagnosis["component"] == "valve"
    assert diagnosis["probability"] > 0.5
    assert diagnosis["result"]["hypotheses"][0]["name"] == "valve"
    valve = next(e for e in diagnosis["estimates"] if e["component"] == "valve")
    assert valve["quantity"] == "cv" and valve["unit"] == "m"
    assert valve["low"] <= 60e-6 <= valve["high"]
    assert valve["value"] == pytest.approx(60e-6, rel=0.03)
    # the cylinder is healthy: its closed-form clearance stays nominal
    cylinder = next(e for e in diagnosis["estimates"] if e["component"] == "cylinder")
    assert cylinder["source"] == "direct"
    assert cylinder["value"] == pytest.approx(83e-6, rel=0.05)
    after = server.row_counts()
    assert after["measurements"] == before["measurements"] + 1
    assert after["diagnoses"] == before["diagnoses"] + 1
    assert after["diagnosis_estimates"] == before["diagnosis_estimates"] + len(
        diagnosis["estimates"])
    assert diagnosis["id"] is not None and len(diagnosis["measurement_ids"]) == 1
    assert diagnosis["measured_at"] == "2026-03-01T08:00:00Z" and body["notes"] == []


def test_a_stored_record_without_its_time_is_kept_at_the_requests_time_and_says_so(
        server: LiveServer) -> None:
    record = simulated_record(server, WORN_VALVE)
    record.pop("measured_at", None)
    body = server.client.post("/diagnose", json={"records": [record, record]},
                              headers=server.auth).json()
    (note,) = body["notes"]
    assert note.startswith("records[0], records[1] state no measured_at: stored at")
    stated = body["diagnoses"][0]["measured_at"]
    assert stated in note          # the time it was stored at, as the history shows it
    # not stored: nothing filled in, nothing to say
    assert server.client.post("/diagnose", json={"record": record, "store": False}
                              ).json()["notes"] == []


def test_a_healthy_record_is_healthy(server: LiveServer) -> None:
    record = simulated_record(server)
    body = server.client.post("/diagnose", json={"record": record, "store": False}).json()
    assert body["diagnoses"][0]["top"] == "healthy"


def test_not_storing_needs_no_key_and_leaves_the_store_alone(server: LiveServer) -> None:
    record = simulated_record(server, {"cylinder.cc": 120e-6})
    before = server.row_counts()
    response = server.client.post("/diagnose", json={"record": record, "store": False})
    assert response.status_code == 200, response.text
    (diagnosis,) = response.json()["diagnoses"]
    assert diagnosis["top"] == "cylinder"
    assert diagnosis["id"] is None and diagnosis["measurement_ids"] == []
    assert server.row_counts() == before


def test_storing_needs_the_key(server: LiveServer) -> None:
    record = simulated_record(server, WORN_VALVE)
    before = server.row_counts()
    response = server.anon.post("/diagnose", json={"record": record})
    assert response.status_code == 401
    assert response.json()["error"]["type"] == "AuthError"
    wrong = server.client.post("/diagnose", json={"record": record},
                               headers={"X-API-Key": "hd_000000000000_nope"})
    assert wrong.status_code == 401
    assert server.row_counts() == before


def test_a_batch_is_diagnosed_record_by_record(server: LiveServer) -> None:
    records = [simulated_record(server, WORN_VALVE),
               simulated_record(server, {"cylinder.cc": 120e-6})]
    before = server.row_counts()
    response = server.client.post("/diagnose", json={"records": records}, headers=server.auth)
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["mode"] == "each"
    assert [d["top"] for d in body["diagnoses"]] == ["valve", "cylinder"]
    assert [d["records"] for d in body["diagnoses"]] == [["records[0]"], ["records[1]"]]
    assert server.row_counts()["diagnoses"] == before["diagnoses"] + 2


def test_a_joint_diagnosis_keeps_every_record_and_one_result(server: LiveServer) -> None:
    records = [simulated_record(server, WORN_VALVE, load=load,
                                measured_at=f"2026-04-01T08:0{i}:00Z")
               for i, load in enumerate((2100.0, 4200.0))]
    before = server.row_counts()
    response = server.client.post("/diagnose", json={"records": records, "joint": True},
                                  headers=server.auth)
    assert response.status_code == 200, response.text
    (diagnosis,) = response.json()["diagnoses"]
    assert diagnosis["top"] == "valve"
    assert diagnosis["result"]["n_records"] == 2
    assert diagnosis["measured_at"] == "2026-04-01T08:01:00Z"
    after = server.row_counts()
    assert after["measurements"] == before["measurements"] + 2
    assert after["diagnoses"] == before["diagnoses"] + 1
    assert len(diagnosis["measurement_ids"]) == 2
    # which record the closed-form inversions come from (the console's page showed the
    # other record's readings beside them without a word): the most precise, at 4.2 kN
    assert [n for n in diagnosis["result"]["notes"] if n.startswith(
        "the direct inversion of cv (paper 002 §2.7) is that of record 2 of the 2, the most "
        "precise of the 2")]
    # the history keeps the fit to both records, not the first record's closed form
    valve = next(e for e in diagnosis["estimates"] if e["component"] == "valve")
    direct = diagnosis["result"]["direct_inversions"]["cv"]
    assert valve["source"] == "hypothesis" and valve["low"] <= 60e-6 <= valve["high"]
    assert valve["high"] - valve["low"] < direct["high"] - direct["low"]


def test_a_visit_whose_instruments_share_their_errors_states_wider_intervals(
        server: LiveServer) -> None:
    """The same two records of a worn spool, diagnosed jointly as independent and as read
    by the same instruments (``calibration_share`` 1): the same name and estimate, the
    valve's interval wider where the records' errors do not average out
    (:mod:`diagnostics.shared_errors`); the history keeps each record's share."""
    records = [simulated_record(server, WORN_VALVE, load=load) for load in (2100.0, 4200.0)]
    answers = {}
    for share in (None, 1.0):
        sent = [r | ({} if share is None else {"calibration_share": share}) for r in records]
        response = server.client.post("/diagnose", json={"records": sent, "joint": True},
                                      headers=server.auth)
        assert response.status_code == 200, response.text
        (answers[share],) = response.json()["diagnoses"]
    valves = {k: next(e for e in d["estimates"] if e["component"] == "valve")
              for k, d in answers.items()}
    assert answers[None]["top"] == answers[1.0]["top"] == "valve"
    assert valves[1.0]["value"] == pytest.approx(valves[None]["value"], rel=1e-9)
    width = {k: v["high"] - v["low"] for k, v in valves.items()}
    assert width[1.0] > 1.2 * width[None]
    assert valves[1.0]["low"] <= 60e-6 <= valves[1.0]["high"]
    for mid in answers[1.0]["measurement_ids"]:
        stored = server.client.get(f"/measurements/{mid}", headers=server.auth)
        assert stored.status_code == 200, stored.text
        assert stored.json()["record"]["calibration_share"] == 1.0
    for mid in answers[None]["measurement_ids"]:
        stored = server.client.get(f"/measurements/{mid}", headers=server.auth)
        assert "calibration_share" not in stored.json()["record"]
    assert [n for n in answers[1.0]["result"]["notes"] if n.startswith("the intervals count")]
    # the schema's example of such a visit (a spool worn to 60 µm read at two loads)
    spec = server.client.get("/openapi.json").json()
    (example,) = [e for e in spec["components"]["schemas"]["DiagnoseRequest"]["examples"]
                  if e.get("joint")]
    response = server.client.post("/diagnose", json=example, headers=server.auth)
    assert response.status_code == 200, response.text
    (visit,) = response.json()["diagnoses"]
    assert visit["top"] == "valve" and visit["result"]["n_records"] == 2


def test_a_record_without_a_version_means_the_latest_in_a_joint_visit(
        server: LiveServer) -> None:
    """One record stating version 1 and one stating none (both version 1, the latest) were
    refused as two versions; once the rig has a version 2, the one stating none means 2
    and the visit is refused naming it."""
    rig = new_rig(server, "joint-versions")
    first = simulated_record(server) | {"rig_id": rig["id"], "rig_version": 1}
    second = simulated_record(server, load=4200.0) | {"rig_id": rig["id"]}
    body = {"records": [first, second], "joint": True, "store": False}
    accepted = server.client.post("/diagnose", json=body, headers=server.auth)
    assert accepted.status_code == 200, accepted.text
    assert accepted.json()["diagnoses"][0]["rig_version"] == 1
    document = server.client.get(f"/rigs/{rig['id']}").json()["document"]
    updated = server.client.put(f"/rigs/{rig['id']}", json={
        "document": document, "comment": "a second version"}, headers=server.auth)
    assert updated.status_code == 200, updated.text
    refused = server.client.post("/diagnose", json=body, headers=server.auth)
    assert refused.status_code == 422, refused.text
    assert refused.json()["error"]["field"] == "records[1].rig_version"
    assert "the latest (2)" in refused.json()["error"]["message"]
    # the console's path (plan_groups) resolves alike
    from app.services.diagnosis import joint_rig

    with server.session() as session:
        resolved = joint_rig(session, server.app.state.rigs, rig["id"],
                             [("records[0]", 1), ("records[1]", 1)])
        assert resolved.version == 1


def test_a_joint_diagnosis_needs_one_rig(server: LiveServer) -> None:
    other = new_rig(server, "diagnose-other")
    records = [simulated_record(server), simulated_record(server) | {"rig_id": other["id"]}]
    response = server.client.post("/diagnose", json={"records": records, "joint": True},
                                  headers=server.auth)
    assert response.status_code == 422
    assert response.json()["error"]["field"] == "records[1].rig_id"


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"flow_C": -1.0}, "records[1].flow_C"),
        ({"flow_B": {"value": 4e-4, "u": 1e-6, "bound": 1e-6}}, "records[1].flow_B"),
        ({"flow_B": {"value": 4e-4, "u": -1.0}}, "records[1].flow_B.u"),
        ({"measured_at": "2026-03-01T08:00:00"}, "records[1].measured_at"),
        ({"p1": "NaN"}, "records[1].p1"),  # text, not a number
        ({"rig_id": "abc"}, "records[1].rig_id"),
        ({"measured_at": "2999-01-01T00:00:00Z"}, "records[1].measured_at"),  # the future
        ({"measured_at": "1900-01-01T00:00:00Z"}, "records[1].measured_at"),  # unset clock
        ({"condition": {"load_force": 2100.0}}, "records[1].condition.oil_temperature"),
        ({"condition": {"oil_temperature": 40.0}}, "records[1].condition.load_force"),
        ({"speed_work": 0.18, "speed_return": 0.215, "velocity_ratio": 0.5},
         "records[1].velocity_ratio"),
        ({"rig_version": 0}, "records[1].rig_version"),
        ({"calibration_share": 1.5}, "records[1].calibration_share"),
        ({"calibration_share": -0.1}, "records[1].calibration_share"),
        ({"calibration_share": "all"}, "records[1].calibration_share"),
    ],
)
def test_a_bad_record_is_422_naming_the_field_and_stores_nothing(
    server: LiveServer, change: dict[str, Any], field: str
) -> None:
    good = simulated_record(server, WORN_VALVE)
    before = server.row_counts()
    response = server.client.post("/diagnose", json={"records": [good, good | change]},
                                  headers=server.auth)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == field
    assert server.row_counts() == before


@pytest.mark.parametrize(
    ("body", "field"),
    [({}, "records"), ({"records": []}, "records"), ({"record": {"rig_id": 1}}, "record.condition"),
     ({"record": {"rig_id": 1, "condition": {"oil_temperature": 40.0, "load_force": 1.0}},
       "joint": True}, "joint")],
)
def test_malformed_bodies_are_422(server: LiveServer, body: dict[str, Any], field: str) -> None:
    response = server.client.post("/diagnose", json=body, headers=server.auth)
    assert response.status_code == 422
    assert response.json()["error"]["field"] == field


def test_unknown_rig_and_version_are_404(server: LiveServer) -> None:
    record = simulated_record(server)
    before = server.row_counts()
    unknown_rig = server.client.post("/diagnose", json={"record": record | {"rig_id": 9999}},
                                     headers=server.auth)
    assert unknown_rig.status_code == 404
    assert unknown_rig.json()["error"]["field"] == "record.rig_id"
    unknown_version = server.client.post(
        "/diagnose", json={"records": [record | {"rig_version": 7}]}, headers=server.auth)
    assert unknown_version.status_code == 404
    assert unknown_version.json()["error"]["field"] == "records[0].rig_version"
    assert server.row_counts() == before


def test_every_refused_record_of_a_batch_is_named_first_to_last(server: LiveServer) -> None:
    """A batch with p1 in bar (record 1), flow_B in l/min (2) and 400 °C (3) named only
    records[3], then records[1] once that was fixed, then records[2] (a fleet integrator's
    pass): every refusal now, in request order, and nothing stored."""
    good = simulated_record(server, WORN_VALVE, measured_at="2026-05-08T08:00:00Z")
    hot = dict(good["condition"], oil_temperature=400.0)
    batch = [good, good | {"p1": good["p1"] / 1e5}, good | {"flow_B": good["flow_B"] * 6e4},
             good | {"condition": hot}]
    before = server.row_counts()
    response = server.client.post("/diagnose", json={"records": batch}, headers=server.auth)
    assert response.status_code == 422, response.text
    error = response.json()["error"]
    assert error["field"] == "records[1].p1" and "2 more refused" in error["message"]
    assert [d["field"] for d in error["details"]] == [
        "records[1].p1", "records[2].flow_B", "records[3].condition.oil_temperature"]
    assert server.row_counts() == before


def test_a_record_impossible_on_its_rig_is_422(server: LiveServer) -> None:
    record = simulated_record(server) | {"speed_work": 5.0, "speed_return": 6.0}
    response = server.client.post("/diagnose", json={"record": record, "store": False})
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"].startswith("record.")


def test_the_answer_gives_the_time_in_utc_as_it_is_read_back(server: LiveServer) -> None:
    """A record stated at 10:00+02:00 was echoed with +02:00 while GET /diagnoses read it
    back as 08:00Z: one diagnosis, two spellings of its time."""
    for compact, hour in ((False, 10), (True, 11)):
        record = simulated_record(server, WORN_VALVE,
                                  measured_at=f"2026-11-23T{hour}:00:00+02:00")
        answer = server.client.post("/diagnose", json={"record": record, "compact": compact},
                                    headers=server.auth).json()["diagnoses"][0]
        assert answer["measured_at"] == f"2026-11-23T{hour - 2:02d}:00:00Z"
        stored = server.client.get(f"/diagnoses/{answer['id']}").json()
        assert stored["measured_at"] == answer["measured_at"]


def test_the_same_record_stored_twice_is_a_409_naming_the_first_and_stores_nothing(
        server: LiveServer) -> None:
    """A double submit without an Idempotency-Key stored the record twice and the trend
    fitted both points (an engineer's pass).  The same record at another time, or not
    stored, is diagnosed; so is the same record against another rig version."""
    record = simulated_record(server, WORN_VALVE, measured_at="2026-05-07T08:00:00Z")
    first = server.client.post("/diagnose", json={"record": record}, headers=server.auth)
    assert first.status_code == 200, first.text
    first_id = first.json()["diagnoses"][0]["id"]
    before = server.row_counts()
    again = server.client.post("/diagnose", json={"record": record}, headers=server.auth)
    assert again.status_code == 409, again.text
    error = again.json()["error"]
    assert error["field"] == "measured_at" and f"diagnosis {first_id}" in error["message"]
    assert server.row_counts() == before
    assert server.client.post("/diagnose", json={"record": record, "store": False},
                              headers=server.auth).status_code == 200
    later = record | {"measured_at": "2026-05-07T08:00:01Z"}
    assert server.client.post("/diagnose", json={"record": later},
                              headers=server.auth).status_code == 200
    # the same instant in another offset is the same record (a fleet integrator's pass:
    # a gateway's local time stored it twice)
    local = record | {"measured_at": "2026-05-07T10:00:00+02:00"}
    assert server.client.post("/diagnose", json={"record": local},
                              headers=server.auth).status_code == 409
    # nor is its stamp with fractions of a second a re-export cut (a reliability
    # engineer's pass: 15:45:28.070615 re-sent as 15:45:28 was a second visit)
    cut = record | {"measured_at": "2026-05-07T07:59:59.930Z"}
    refused = server.client.post("/diagnose", json={"record": cut}, headers=server.auth)
    assert refused.status_code == 409 and f"diagnosis {first_id}" in refused.text
    # in a batch: which record, and a record twice in one request is said as such (it
    # named a diagnosis id of the rolled-back transaction, given later to another)
    new = record | {"measured_at": "2026-05-07T09:00:00Z"}
    before = server.row_counts()
    batch = server.client.post("/diagnose", json={"records": [new, record]},
                               headers=server.auth)
    assert batch.status_code == 409 and batch.json()["error"]["field"] == "records[1].measured_at"
    twice = server.client.post("/diagnose", json={"records": [new, new]}, headers=server.auth)
    assert twice.status_code == 409, twice.text
    assert twice.json()["error"]["field"] == "records[1]"
    assert "records[1] repeats records[0]" in twice.json()["error"]["message"]
    assert server.row_counts() == before


def test_a_time_in_the_future_is_told_against_the_clock_itself() -> None:
    """It named the clock plus the day's allowance as "the service's clock" (an operator's
    pass)."""
    import datetime as dt
    import re

    from app.schemas.times import measurement_time_problem

    now = dt.datetime.now(dt.UTC)
    problem = measurement_time_problem(now + dt.timedelta(days=3))
    assert problem is not None and "more than a day after the service's clock" in problem
    said = re.search(r"clock, ([^)]+)\)", problem)
    assert said is not None
    assert abs(dt.datetime.fromisoformat(said.group(1)) - now) < dt.timedelta(minutes=1)
    assert measurement_time_problem(now + dt.timedelta(hours=23)) is None
