"""POST /rigs/{id}/commission and ``hydrodiag commission``: healthy records of the rig as
built give its uncertain parameters, stored as a new rig version that later diagnoses use."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from app.cli import cli
from sim.rigs import reference_rig
from tests.app.conftest import cli_store, new_rig
from tests.app.live import LiveServer
from tests.diagnostics.synth import FULL, readings
from tests.diagnostics.test_commissioning import TRUTH, true_rig

FIELDS = (*FULL, "pump_flow")


def healthy_bodies(rig_id: int, seed: int = 3) -> list[dict[str, Any]]:
    """Records of the as-built rig (parameters off the document's by TRUTH), with the
    instrument noise of the default classes (uniform within ±1 % flow, ±0.25 % pressure,
    ±0.5 % speed)."""
    actual = true_rig()
    rng = np.random.default_rng(seed)
    bounds = {"pump_pressure": 0.0025, "p1": 0.0025, "p2": 0.0025, "flow_B": 0.01,
              "flow_C": 0.01, "pump_flow": 0.01, "speed_work": 0.005, "speed_return": 0.005}
    out = []
    for load in (2100.0, 4200.0, 6300.0):
        for temperature in (35.0, 55.0):
            vals = readings(actual, {}, load, temperature)
            body: dict[str, Any] = {
                "rig_id": rig_id,
                "condition": {"oil_temperature": temperature, "load_force": load}}
            for f in FIELDS:
                body[f] = vals[f] * (1.0 + rng.uniform(-0.5, 0.5) * bounds[f])
            out.append(body)
    return out


def test_commissioning_stores_a_version_that_explains_the_rig(server: LiveServer) -> None:
    rig = new_rig(server, "to-commission")
    rig_id = rig["id"]
    records = healthy_bodies(rig_id)
    # before: the document does not describe the rig; a healthy record is not explained
    probe = dict(records[1], condition={"oil_temperature": 45.0, "load_force": 3000.0})
    probe.update({f: readings(true_rig(), {}, 3000.0, 45.0)[f] for f in FIELDS})
    before = server.client.post("/diagnose", json={"record": probe, "store": False}).json()
    assert before["diagnoses"][0]["explained"] is False

    no_key = server.anon.post(f"/rigs/{rig_id}/commission", json={"records": records})
    assert no_key.status_code == 401
    response = server.client.post(f"/rigs/{rig_id}/commission",
                                  json={"records": records}, headers=server.auth)
    assert response.status_code == 201, response.text
    body = response.json()
    assert body["from_version"] == 1 and body["version"] == 2
    base = reference_rig().base
    fitted = {p["name"]: p for p in body["parameters"]}
    for name, factor in TRUTH.items():
        p = fitted[name]
        assert p["low"] <= base[name] * factor <= p["high"], p
    stored = server.client.get(f"/rigs/{rig_id}/versions/2").json()
    lc = stored["document"]["components"]["cylinder"]["parameters"]["Lc"]
    assert lc["value"] == pytest.approx(fitted["cylinder.Lc"]["value"])
    assert "commissioned" in lc["source"]
    after = server.client.post("/diagnose", json={"record": probe, "store": False}).json()
    (d,) = after["diagnoses"]
    assert d["rig_version"] == 2 and d["explained"] is True and d["top"] == "healthy"


def test_bad_commissioning_requests_are_422_and_store_nothing(server: LiveServer) -> None:
    rig = new_rig(server, "commission-errors")
    rig_id = rig["id"]
    records = healthy_bodies(rig_id)[:2]
    cases = [({"records": records, "parameters": ["cylinder.cc"]}, "parameters[0]"),
             ({"records": [dict(records[0], rig_id=1)]}, "records[0].rig_id"),
             ({"records": [dict(records[0], speed_work=5.0)]}, "records[0].speed_work"),
             ({"records": [dict(records[0], rig_version=99)]}, "records[0].rig_version")]
    for body, field in cases:
        response = server.client.post(f"/rigs/{rig_id}/commission", json=body,
                                      headers=server.auth)
        assert response.status_code == 422, response.text
        assert response.json()["error"]["field"] == field
    # a record of a worn seal among the healthy ones: no rig of the document explains
    # them; refused, naming that record, nothing stored
    worn = healthy_bodies(rig_id)
    vals = readings(true_rig(), {"cylinder.cc": 1.6 * 83e-6}, 4200.0, 55.0)
    worn[3].update({f: vals[f] for f in FIELDS})
    response = server.client.post(f"/rigs/{rig_id}/commission", json={"records": worn},
                                  headers=server.auth)
    assert response.status_code == 422, response.text
    error = response.json()["error"]
    assert error["field"] == "records[3]"
    assert "not those of one healthy rig" in error["message"]
    assert "nothing stored" in error["message"]
    versions = server.client.get(f"/rigs/{rig_id}/versions").json()
    assert versions["total"] == 1
    missing = server.client.post("/rigs/9999/commission", json={"records": records},
                                 headers=server.auth)
    assert missing.status_code == 404


def test_cli_commission(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cli_store(monkeypatch, tmp_path / "store")
    runner = CliRunner()
    path = tmp_path / "records.yaml"
    path.write_text(yaml.safe_dump(healthy_bodies(1)))
    result = runner.invoke(cli, ["commission", str(path), "--rig", "1", "--json"])
    assert result.exit_code == 0, result.output
    body = json.loads(result.stdout)
    assert body["version"] == body["from_version"] + 1
    assert {p["name"] for p in body["parameters"] if p["identifiable"]} >= {
        "cylinder.Lc", "valve.K"}
    table = runner.invoke(cli, ["commission", str(path), "--rig", "1", "--parameter",
                                "valve.K"])
    assert table.exit_code == 0, table.output
    assert "valve.K" in table.output
    # the fitted value and its interval carry the unit, as the value before does
    # one unit column serves before, fitted and interval (the fitted had none)
    assert "unit" in table.output and "m^3/(s*Pa^" in table.output and "…" not in (
        next(line for line in table.output.splitlines() if "valve.K" in line).split("│")[2])
    bad = runner.invoke(cli, ["commission", str(path), "--rig", "1", "--parameter", "x.y"])
    # main() prints the error and exits 1; the runner keeps the exception
    assert bad.exit_code != 0 and getattr(bad.exception, "field", None) == "--parameter"
    assert "x.y" in str(bad.exception)
    # a file without records names the file, not the API's "records" field
    (tmp_path / "empty.json").write_text("{}")
    empty = runner.invoke(cli, ["commission", str(tmp_path / "empty.json"), "--rig", "1"])
    assert empty.exit_code != 0 and getattr(empty.exception, "field", None) == "FILE"
    assert "holds no records" in str(empty.exception)
    # last (a new store: under make test-postgres a new database, never this one again):
    # the same records read by the same instruments, on the new store's rig 1 (the first
    # commissioning's document): the fit weighs the visit's whole covariance
    # (diagnostics/shared_errors.py)
    cli_store(monkeypatch, tmp_path / "store-shared")
    shared = runner.invoke(cli, ["commission", str(path), "--rig", "1", "--json",
                                 "--calibration-share", "1"])
    assert shared.exit_code == 0, shared.output
    for apart, told in zip(body["parameters"], json.loads(shared.stdout)["parameters"],
                           strict=True):
        assert told["name"] == apart["name"] and told["before"] == apart["before"]
        if apart["identifiable"]:
            assert (told["low"], told["high"]) != pytest.approx((apart["low"], apart["high"]),
                                                                rel=1e-4)
    over = runner.invoke(cli, ["commission", str(path), "--rig", "1", "--calibration-share",
                               "-1"])
    assert over.exit_code == 2 and "--calibration-share" in over.output, over.output


def test_a_worn_record_is_not_absorbed_into_the_document(server: LiveServer) -> None:
    """One record of a worn spool (cv 60 µm for 34) given as healthy: the fit explains it
    by a land 81 % shorter, 3.4 prior σ from the document's value.  Stored, that version
    would diagnose the same worn spool as healthy; refused naming ``beyond_prior``, and
    stored when it is sent, the move stated per parameter (``prior_shift``)."""
    rig_id = new_rig(server, "commission-worn")["id"]
    vals = readings(reference_rig(), {"valve.cv": 60e-6}, 2100.0, 40.0)
    record = {"rig_id": rig_id, "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
              **{f: vals[f] for f in FULL}}
    refused = server.client.post(f"/rigs/{rig_id}/commission", json={"records": [record]},
                                 headers=server.auth)
    assert refused.status_code == 422, refused.text
    error = refused.json()["error"]
    assert error["field"] == "beyond_prior" and "valve.Ls" in error["message"]
    assert server.client.get(f"/rigs/{rig_id}/versions").json()["total"] == 1
    stored = server.client.post(f"/rigs/{rig_id}/commission", json={
        "records": [record], "beyond_prior": True}, headers=server.auth)
    assert stored.status_code == 201, stored.text
    ls = next(p for p in stored.json()["parameters"] if p["name"] == "valve.Ls")
    assert ls["prior_shift"] < -3.0 and ls["value"] < 0.3 * ls["before"]
    # stored beyond the guard on request, the value is the origin from then on: the same
    # records again confirm it, where every later commissioning was refused (a
    # verification pass)
    again = server.client.post(f"/rigs/{rig_id}/commission", json={"records": [record]},
                               headers=server.auth)
    assert again.status_code == 200, again.text     # nothing new to store
    assert again.json()["stored"] is False and "confirm the document" in \
        again.json()["statements"][0]


def test_a_second_commissioning_cannot_walk_past_the_guard(server: LiveServer) -> None:
    """A spool worn to 49 µm given as healthy reads as a land 67 % shorter (2.2 prior σ):
    stored, and said with the wear it reads as; a worn-on spool (60 µm) then moved the
    commissioned land only 1.1 σ more and was stored too, where from the author's value it
    is 3.3 σ (a commissioning engineer's pass).  The guard measures from the author's."""
    rig_id = new_rig(server, "commission-walk")["id"]

    def worn(cv: float) -> dict[str, Any]:
        vals = readings(reference_rig(), {"valve.cv": cv}, 2100.0, 40.0)
        return {"rig_id": rig_id, "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
                **{f: vals[f] for f in FULL}}

    first = server.client.post(f"/rigs/{rig_id}/commission", json={"records": [worn(49e-6)]},
                               headers=server.auth)
    assert first.status_code == 201, first.text
    said = [s for s in first.json()["statements"] if s.startswith("valve.Ls (")]
    assert said and "reads as the spool at 1.4" in said[0], said
    second = server.client.post(f"/rigs/{rig_id}/commission", json={"records": [worn(60e-6)]},
                                headers=server.auth)
    assert second.status_code == 422, second.text
    error = second.json()["error"]
    assert error["field"] == "beyond_prior" and "as its author wrote it" in error["message"]
    assert server.client.get(f"/rigs/{rig_id}/versions").json()["total"] == 2
    # the author's original file stored again (for an unrelated fix) undoes the
    # commissioning: said (it was silent, and every later diagnosis unexplained)
    original = server.client.get(f"/rigs/{rig_id}/versions/1").json()["document"]
    fixed = original | {"title": "hose fixed"}
    put = server.client.put(f"/rigs/{rig_id}", json={"document": fixed}, headers=server.auth)
    assert put.status_code == 200, put.text
    notes = put.json()["notes"]
    assert any(n.startswith("valve.Ls was commissioned (") and "undone" in n for n in notes)
    assert all(n.split(" ")[0] in ("valve.Ls", "valve.K", "pump.Rlp", "cylinder.Lc",
                                   "cylinder.Fu", "cylinder.Kf") for n in notes), notes
    assert server.client.get(f"/rigs/{rig_id}").json()["notes"] == []


def test_records_that_confirm_the_document_store_no_version(server: LiveServer) -> None:
    """A rig as documented: each pinned-down interval holds the document's value, and a
    new version would only split the history and trends (the /docs example stored one
    from a single record; a first-day user pass)."""
    rig = new_rig(server, "as-documented")
    rig_id = rig["id"]
    documented = reference_rig()
    rng = np.random.default_rng(5)
    records = []
    for load in (2100.0, 4200.0, 6300.0):
        for temperature in (35.0, 55.0):
            vals = readings(documented, {}, load, temperature)
            records.append({"rig_id": rig_id, "condition": {"oil_temperature": temperature,
                                                            "load_force": load},
                            **{f: vals[f] * (1.0 + rng.uniform(-0.002, 0.002))
                               for f in FIELDS}})
    before = server.row_counts()
    response = server.client.post(f"/rigs/{rig_id}/commission", json={"records": records},
                                  headers=server.auth)
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["stored"] is False and body["version"] == body["from_version"] == 1
    assert body["statements"][0].startswith("the records confirm the document")
    assert all(p["low"] <= p["before"] <= p["high"]
               for p in body["parameters"] if p["identifiable"])
    assert server.row_counts() == before
    assert server.client.get(f"/rigs/{rig_id}").json()["latest_version"] == 1


def test_a_commissioned_version_keeps_the_authors_units_and_sources() -> None:
    """A commissioned version rewrote an author's 10 mm seal land as 0.01035064160016852 m
    and dropped its source (a rig author's pass): the fitted value is written in the unit
    the document used, its source says what it was and keeps the old one."""
    import copy

    from app.services.commissioning import commissioned_document
    from diagnostics.commissioning import commission
    from sim.rigs import load_rig, reference_rig_document
    from tests.diagnostics.test_commissioning import healthy_records

    doc = copy.deepcopy(reference_rig_document())
    doc["components"]["cylinder"]["parameters"]["Lc"] = {
        "value": 12.31, "unit": "mm", "source": "seal land, drawing 4711"}
    rig = load_rig(doc)
    fit = commission(rig, healthy_records(true_rig(), 0))
    (lc_fit,) = [p for p in fit.parameters if p.name == "cylinder.Lc"]
    assert lc_fit.identifiable
    units = {}
    for p in fit.parameters:
        decl = rig.circuit.parameter(*p.name.split("."))
        assert decl is not None
        units[p.name] = decl.unit
    out = commissioned_document(doc, fit, units)
    lc = out["components"]["cylinder"]["parameters"]["Lc"]
    assert lc["unit"] == "mm" and lc["value"] == pytest.approx(lc_fit.value * 1e3, rel=1e-12)
    assert "was 12.31 mm (seal land, drawing 4711)" in lc["source"]
    assert load_rig(out).base["cylinder.Lc"] == pytest.approx(lc_fit.value, rel=1e-12)
