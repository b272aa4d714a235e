"""POST /rigs/{rig_id}/rediagnose and ``hydrodiag rigs rediagnose``: a rig's history
diagnosed again against its latest version, the old diagnoses superseded, not doubled."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path
from typing import Any

import httpx
import pytest
from typer.testing import CliRunner

from app.cli import cli
from sim.errors import InputError
from sim.rigs import reference_rig_document
from tests.app.conftest import new_rig, simulated_record
from tests.app.live import LiveServer

POLL_TIMEOUT_S = 120.0
#: The commissioned seal: 15 % shorter than the reference document's.
SHORTER = 0.85


def follow(server: LiveServer, job_id: str) -> dict[str, Any]:
    """Poll job ``job_id`` until it ends; return it."""
    deadline = time.monotonic() + POLL_TIMEOUT_S
    while (body := server.client.get(f"/jobs/{job_id}").json())["status"] not in (
            "succeeded", "failed", "cancelled"):
        if time.monotonic() > deadline:
            raise AssertionError(f"job {job_id} stuck at {body['progress']}")
        time.sleep(0.05)
    return dict(body)


def shorter_seal(name: str) -> dict[str, Any]:
    """The reference document named ``name`` with the seal length × :data:`SHORTER`."""
    document = reference_rig_document() | {"name": name}
    document["components"]["cylinder"]["parameters"]["Lc"]["value"] *= SHORTER
    return document


def post(server: LiveServer, body: dict[str, Any]) -> dict[str, Any]:
    response = server.client.post("/diagnose", json=body, headers=server.auth)
    assert response.status_code == 200, response.text
    return dict(response.json())


@pytest.fixture(scope="module")
def history(server: LiveServer) -> dict[str, Any]:
    """A rig diagnosed on three visits against version 1 (a healthy rig, a worn seal, and
    a joint visit of that seal at two loads), then given a 15 % shorter seal (version 2)."""
    rig_id = int(new_rig(server, "rediagnose-rig")["id"])
    worn = {"cylinder.cc": 110e-6}
    single = [post(server, {"record": simulated_record(
        server, overrides, rig_id=rig_id, measured_at=when)})["diagnoses"][0]
        for overrides, when in (({}, "2026-03-01T08:00:00Z"),
                                (worn, "2026-04-01T08:00:00Z"))]
    joint = post(server, {"joint": True, "records": [
        simulated_record(server, worn, rig_id=rig_id, load=load,
                         measured_at=f"2026-05-01T08:0{i}:00Z")
        for i, load in enumerate((2100.0, 4200.0))]})["diagnoses"][0]
    response = server.client.put(f"/rigs/{rig_id}", json={"document": shorter_seal(
        "rediagnose-rig"), "comment": "commissioned seal length"}, headers=server.auth)
    assert response.status_code == 200, response.text
    return {"rig_id": rig_id, "old": [*single, joint]}


def test_the_history_is_diagnosed_again_and_the_old_diagnoses_superseded(
        server: LiveServer, history: dict[str, Any]) -> None:
    rig_id, old = history["rig_id"], history["old"]
    before = server.client.get(f"/rigs/{rig_id}/trends", params={"component": "cylinder"}
                               ).json()["components"][0]
    assert before["left_out"] == 3 and before["points"] == []
    assert f"POST /rigs/{rig_id}/rediagnose" in before["message"]

    response = server.client.post(f"/rigs/{rig_id}/rediagnose", headers=server.auth)
    assert response.status_code == 202, response.text
    accepted = response.json()
    assert (accepted["versions"], accepted["rig_version"], accepted["n_diagnoses"]) == (
        [1], 2, 3)
    assert response.headers["location"] == f"/jobs/{accepted['job_id']}"
    job = follow(server, accepted["job_id"])
    assert job["status"] == "succeeded", job
    result = job["result"]
    assert (result["rediagnosed"], result["skipped"], result["errors"]) == (3, 0, [])
    by = {r["diagnosis_id"]: r["by"] for r in result["replaced"]}
    assert sorted(by) == sorted(d["id"] for d in old)

    # listings read the current diagnoses: three, each against version 2, none doubled
    current = server.client.get("/diagnoses", params={"rig_id": rig_id}).json()
    assert current["total"] == 3
    assert {d["rig_version"] for d in current["items"]} == {2}
    assert {d["supersedes"] for d in current["items"]} == set(by)
    every = server.client.get("/diagnoses", params={"rig_id": rig_id, "superseded": True}
                              ).json()
    assert every["total"] == 6
    for d in old:
        stored = server.client.get(f"/diagnoses/{d['id']}").json()
        new = server.client.get(f"/diagnoses/{by[d['id']]}").json()
        assert stored["superseded_by"] == new["id"] and new["superseded_by"] is None
        # the same records: the joint visit's two, kept with the same one
        assert new["measurement_ids"] == stored["measurement_ids"] == d["measurement_ids"]
        assert new["measurement_id"] == stored["measurement_id"]
        assert new["result"]["record_index"] == stored["result"]["record_index"]
        # each record reads back both diagnoses made from it
        for m in d["measurement_ids"]:
            ids = server.client.get(f"/measurements/{m}").json()["diagnosis_ids"]
            assert {d["id"], new["id"]} <= set(ids)
        # physics: the same leak through a seal 15 % shorter.  Laminar annulus flow
        # Q = π·d·c³·Δp/(12·μ·L) (paper 002 eqs. 36, 50) keeps c³/L, so the clearance shrinks by
        # 0.85^(1/3) = 0.9473; the Couette term (∝ c·v, independent of L) keeps it within
        # 1 % of that
        was = next(e for e in stored["estimates"] if e["component"] == "cylinder")
        now = next(e for e in new["estimates"] if e["component"] == "cylinder")
        assert now["clearance_m"] == pytest.approx(was["clearance_m"] * SHORTER ** (1 / 3),
                                                   rel=0.01)
        assert now["clearance_m"] != pytest.approx(was["clearance_m"], rel=0.03)
        assert new["component"] == stored["component"]

    after = server.client.get(f"/rigs/{rig_id}/trends", params={"component": "cylinder"}
                              ).json()["components"][0]
    assert after["left_out"] == 0 and [p["rig_version"] for p in after["points"]] == [2, 2, 2]
    assert [p["diagnosis_id"] for p in after["points"]] == [by[d["id"]] for d in old]

    # done once: a second run finds nothing to do
    again = server.client.post(f"/rigs/{rig_id}/rediagnose", headers=server.auth).json()
    assert (again["n_diagnoses"], again["versions"]) == (0, [])
    assert follow(server, again["job_id"])["result"]["rediagnosed"] == 0


def test_a_version_with_the_same_parameters_needs_nothing_and_bad_versions_are_422(
        server: LiveServer) -> None:
    rig_id = int(new_rig(server, "rediagnose-same")["id"])
    post(server, {"record": simulated_record(server, rig_id=rig_id,
                                             measured_at="2026-03-01T08:00:00Z")})
    same = reference_rig_document() | {"name": "rediagnose-same"}
    assert server.client.put(f"/rigs/{rig_id}", json={"document": same, "comment": "title"},
                             headers=server.auth).status_code == 200
    accepted = server.client.post(f"/rigs/{rig_id}/rediagnose", headers=server.auth).json()
    assert (accepted["n_diagnoses"], accepted["versions"]) == (0, [])
    # asked for by name, a comparable version is done again
    named = server.client.post(f"/rigs/{rig_id}/rediagnose", json={"versions": [1]},
                               headers=server.auth).json()
    assert named["n_diagnoses"] == 1
    assert follow(server, named["job_id"])["result"]["rediagnosed"] == 1
    for versions, why in (([2], "is the latest"), ([7], "has versions 1 to 2"),
                          ([], "at least 1")):
        r = server.client.post(f"/rigs/{rig_id}/rediagnose", json={"versions": versions},
                               headers=server.auth)
        assert r.status_code == 422, r.text
        assert r.json()["error"]["field"].startswith("versions") and why in r.text
    r = server.client.post(f"/rigs/{rig_id}/rediagnose", json={"version": [1]},
                           headers=server.auth)
    assert r.status_code == 422 and "version" in r.json()["error"]["field"]
    assert server.anon.post(f"/rigs/{rig_id}/rediagnose").status_code == 401
    assert server.client.post("/rigs/31337/rediagnose", headers=server.auth).status_code == 404


def test_deleting_a_record_deletes_its_old_and_new_diagnoses(server: LiveServer) -> None:
    rig_id = int(new_rig(server, "rediagnose-delete")["id"])
    (old,) = post(server, {"record": simulated_record(
        server, rig_id=rig_id, measured_at="2026-03-01T08:00:00Z")})["diagnoses"]
    assert server.client.put(f"/rigs/{rig_id}", json={"document": shorter_seal(
        "rediagnose-delete")}, headers=server.auth).status_code == 200
    job = follow(server, server.client.post(f"/rigs/{rig_id}/rediagnose",
                                            headers=server.auth).json()["job_id"])
    (replaced,) = job["result"]["replaced"]
    r = server.client.delete(f"/measurements/{old['measurement_ids'][0]}", headers=server.auth)
    assert r.status_code == 204, r.text
    for d in (old["id"], replaced["by"]):
        assert server.client.get(f"/diagnoses/{d}").status_code == 404


def test_the_command_line_does_the_same_in_its_own_process(runner: CliRunner,
                                                           tmp_path: Path) -> None:
    """``hydrodiag rigs rediagnose``: the store's history against the latest version, the
    old diagnosis superseded and nothing done twice."""
    from app.cli_support import store_session
    from app.db.models import Diagnosis
    from app.schemas.diagnose import DiagnoseRequest
    from app.services.diagnosis import diagnose_request
    from app.services.rig_cache import RigCache
    from sim.rigs import reference_rig
    from tests.diagnostics.synth import readings

    values = readings(reference_rig(), {"cylinder.cc": 110e-6}, 2100.0, 40.0)
    del values["velocity_ratio"], values["pump_flow"]
    record = {"rig_id": 1, "measured_at": "2026-03-01T08:00:00Z",
              "condition": {"oil_temperature": 40.0, "load_force": 2100.0}} | values
    with store_session() as session:
        diagnose_request(session, RigCache(1), DiagnoseRequest.model_validate(
            {"record": record}))
    name = reference_rig_document()["name"]
    document = tmp_path / "shorter.json"
    document.write_text(json.dumps(shorter_seal(name)))
    assert runner.invoke(cli, ["rigs", "update", "1", str(document)]).exit_code == 0
    done = runner.invoke(cli, ["rigs", "rediagnose", "1"])
    assert done.exit_code == 0, done.output
    assert "1 of 1 diagnoses done again against version 2" in done.output
    again = runner.invoke(cli, ["rigs", "rediagnose", "1"])
    assert again.exit_code == 0 and "nothing to do again" in again.output
    bad = runner.invoke(cli, ["rigs", "rediagnose", "1", "--version", "2"])
    assert bad.exit_code != 0
    assert isinstance(bad.exception, InputError) and "is the latest" in bad.exception.message
    assert bad.exception.field == "--version"
    unknown = runner.invoke(cli, ["rigs", "rediagnose", "77"])
    assert getattr(unknown.exception, "field", None) == "RIG_ID"
    assert runner.invoke(cli, ["rigs", "add", str(_zema())]).exit_code == 0
    circuit = runner.invoke(cli, ["rigs", "rediagnose", "2"])
    assert type(circuit.exception).__name__ == "CircuitError"
    with store_session() as session:
        rows = session.query(Diagnosis).order_by(Diagnosis.id).all()
        assert [r.superseded_by for r in rows] == [rows[1].id, None]


def test_the_console_reads_the_current_diagnoses_and_names_the_replacement(
        server: LiveServer, history: dict[str, Any]) -> None:
    """After the re-diagnosis (the first test of this module ran it), the console's
    history lists the new diagnoses only, and an old one's page says which replaced it."""
    from tests.app.console.conftest import login

    rig_id, old = history["rig_id"], history["old"]
    if server.client.get(f"/diagnoses/{old[0]['id']}").json()["superseded_by"] is None:
        follow(server, server.client.post(f"/rigs/{rig_id}/rediagnose",
                                          headers=server.auth).json()["job_id"])
    new = server.client.get(f"/diagnoses/{old[0]['id']}").json()["superseded_by"]
    with httpx.Client(base_url=server.base_url, timeout=60.0) as client:
        login(server, client)
        listed = client.get("/console/history", params={"rig": rig_id}).text
        shown = {int(i) for i in re.findall(r'href="/console/diagnoses/(\d+)"', listed)}
        assert new in shown and not shown & {d["id"] for d in old}
        page = client.get(f"/console/diagnoses/{old[0]['id']}").text
        assert 'id="superseded"' in page and f'href="/console/diagnoses/{new}"' in page
        replacement = client.get(f"/console/diagnoses/{new}").text
        assert 'id="supersedes"' in replacement
        assert f"records of diagnosis {old[0]['id']}" in replacement


def test_a_partial_re_diagnosis_leaves_a_trend_of_the_new_points_not_a_stale_one(
        server: LiveServer) -> None:
    """A re-diagnosis cancelled half-way (or limited: the oldest go first) leaves the later
    visits' diagnoses on the old version; the trend counted them as later diagnoses that
    estimated nothing and read "stale … they named cylinder" (a checker's pass).
    Diagnoses of a version the trend leaves out are not counted."""
    from app.services.rediagnosis import plan_rediagnosis, run_rediagnosis
    from app.services.rig_cache import RigCache

    rig_id = int(new_rig(server, "rediagnose-partial")["id"])
    for month in range(1, 7):
        post(server, {"record": simulated_record(
            server, {"cylinder.cc": (100 + 2 * month) * 1e-6}, rig_id=rig_id,
            measured_at=f"2026-{month:02d}-01T08:00:00Z")})
    assert server.client.put(f"/rigs/{rig_id}", json={"document": shorter_seal(
        "rediagnose-partial")}, headers=server.auth).status_code == 200
    with server.session() as session:   # a run limited to three: the oldest go first
        first_three = plan_rediagnosis(session, RigCache(1), rig_id, max_diagnoses=3)
    assert first_three.remaining == 3
    done = run_rediagnosis(first_three, server.app.state.sessions)
    assert (done["rediagnosed"], done["remaining"]) == (3, 3)
    cyl = server.client.get(f"/rigs/{rig_id}/trends", params={"component": "cylinder"}
                            ).json()["components"][0]
    assert [p["rig_version"] for p in cyl["points"]] == [2, 2, 2]
    assert cyl["left_out"] == 3 and cyl["status"] != "stale"
    assert cyl["later_diagnoses"] == 0 and "they named" not in cyl["message"]


def _zema() -> Path:
    return Path(__file__).resolve().parents[2] / "sim" / "rigs" / "zema.yaml"
