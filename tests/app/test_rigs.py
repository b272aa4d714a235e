"""Rigs through HTTP: create, read, version, list, delete, and every way to fail."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

import pytest

from app.services.history import ComponentEstimate, record_diagnosis
from tests.app.conftest import new_rig
from tests.app.live import LiveServer


def test_reference_rig_is_preloaded(server: LiveServer) -> None:
    response = server.client.get("/rigs", params={"name": "paper002-reference"})
    assert response.status_code == 200
    body = response.json()
    assert body["total"] == 1
    rig = body["items"][0]
    assert rig["latest_version"] == 1
    assert rig["document"]["schema"] == "hydrodiag.rig/1"
    assert rig["title"] == rig["document"]["title"]


def test_create_get_and_location(server: LiveServer, rig_document: dict) -> None:
    rig_document["name"] = "create-get"
    response = server.client.post("/rigs", json={"document": rig_document, "comment": "first"},
                                  headers=server.auth)
    assert response.status_code == 201, response.text
    created = response.json()
    assert response.headers["location"] == f"/rigs/{created['id']}"
    fetched = server.client.get(f"/rigs/{created['id']}").json()
    assert fetched == created
    assert fetched["name"] == "create-get"
    assert fetched["document"]["components"]["cylinder"]["parameters"]["bore"]["value"] == 0.06


def test_update_adds_versions_and_keeps_old_ones(server: LiveServer, rig_document: dict) -> None:
    rig = new_rig(server, "versioned")
    rig_document["name"] = "versioned"
    rig_document["components"]["cylinder"]["parameters"]["cc"]["value"] = 1.2e-4
    response = server.client.put(f"/rigs/{rig['id']}",
                                 json={"document": rig_document, "comment": "worn piston"},
                                 headers=server.auth)
    assert response.status_code == 200, response.text
    assert response.json()["latest_version"] == 2
    versions = server.client.get(f"/rigs/{rig['id']}/versions").json()
    assert versions["total"] == 2
    assert [v["version"] for v in versions["items"]] == [2, 1]
    assert versions["items"][0]["comment"] == "worn piston"
    first = server.client.get(f"/rigs/{rig['id']}/versions/1").json()
    cc = first["document"]["components"]["cylinder"]["parameters"]["cc"]["value"]
    assert cc == 8.3e-5
    latest = server.client.get(f"/rigs/{rig['id']}").json()
    assert latest["document"]["components"]["cylinder"]["parameters"]["cc"]["value"] == 1.2e-4
    # the same update again (a retry after a lost answer) stores no second, identical version
    again = server.client.put(f"/rigs/{rig['id']}",
                              json={"document": rig_document, "comment": "worn piston"},
                              headers=server.auth)
    assert again.status_code == 200 and again.json()["latest_version"] == 2
    assert server.client.get(f"/rigs/{rig['id']}/versions").json()["total"] == 2


def test_invalid_document_is_422_naming_the_field_and_stores_nothing(
    server: LiveServer, rig_document: dict
) -> None:
    before = server.row_counts()
    rig_document["name"] = "broken"
    rig_document["components"]["cylinder"]["parameters"]["bore"]["value"] = -1.0
    response = server.client.post("/rigs", json={"document": rig_document}, headers=server.auth)
    assert response.status_code == 422
    error = response.json()["error"]
    assert error["type"] == "RigFileError"
    assert error["field"] == "document.components.cylinder.parameters.bore"
    assert "> 0" in error["message"]
    assert server.row_counts() == before


@pytest.mark.parametrize(("mutate", "field", "words"), [
    (lambda d: d.update(colour="red"), "document.colour", "unknown key 'colour'"),
    (lambda d: d["components"]["valve"].update(extra=1), "document.components.valve.extra",
     "unknown key"),
    (lambda d: d["components"]["valve"]["parameters"]["cv"].update(tolerance=3),
     "document.components.valve.parameters.cv.tolerance", "unknown key"),
    (lambda d: d.update(descripton="x"), "document.descripton", "did you mean 'description'"),
    (lambda d: d.update(name="x" * 101), "document.name", "at most 100"),
    (lambda d: d["components"]["valve"]["parameters"]["cv"].update(value=1e300),
     "document.components.valve.parameters.cv", "likely a unit slip"),
    (lambda d: d["components"]["cylinder"]["parameters"]["rod1"].update(value=70.0, unit="mm"),
     "document.components.cylinder.parameters.rod1", "thinner than the bore"),
    # stored, then refused by every simulation (a user pass)
    (lambda d: d["fluid"]["T2"].update(value=40.0, unit="degC"), "document.fluid.T2",
     "reference temperatures must differ"),
    (lambda d: d["fluid"]["nu2"].update(value=1e-3, unit="m^2/s"), "document.fluid.nu2",
     "viscosity must fall"),
    # millimetres typed as metres: a 150 m³ hose, simulated as a stalled piston
    (lambda d: d["components"]["hose_A"]["parameters"]["d"].update(value=12.7, unit="m"),
     "document.components.hose_A.parameters.d", "≤ 0.2"),
])
def test_unknown_keys_and_impossible_geometry_are_refused(
        server: LiveServer, rig_document: dict, mutate: Any, field: str, words: str) -> None:
    """A stored document holds what the schema knows and a geometry that can exist: a
    1e300 m spool clearance was stored and every later steady /simulate answered 500."""
    before = server.row_counts()
    rig_document["name"] = "strict"
    mutate(rig_document)
    response = server.client.post("/rigs", json={"document": rig_document}, headers=server.auth)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == field
    assert words in response.json()["error"]["message"]
    assert server.row_counts() == before


def test_a_rig_file_sent_bare_is_told_to_wrap_it(server: LiveServer, rig_document: dict
                                                 ) -> None:
    """A rig file posted as the body itself was answered "'schema' (did you mean
    'comment'?)" (a user pass); the answer says to send it inside ``document``."""
    before = server.row_counts()
    rig_document["name"] = "bare"
    for send in (server.client.post, lambda url, **kw: server.client.put(url + "/1", **kw)):
        response = send("/rigs", json=rig_document, headers=server.auth)
        assert response.status_code == 422, response.text
        message = response.json()["error"]["message"]
        assert "fields of a document itself" in message and "'document' field" in message
        assert "did you mean" not in message
    assert server.row_counts() == before


def test_failed_update_leaves_the_rig_unchanged(server: LiveServer, rig_document: dict) -> None:
    rig = new_rig(server, "stays-put")
    before = server.row_counts()
    rig_document["name"] = "stays-put"
    rig_document["components"]["valve"] = "not a component"
    response = server.client.put(f"/rigs/{rig['id']}", json={"document": rig_document},
                                 headers=server.auth)
    assert response.status_code == 422
    assert response.json()["error"]["field"].startswith("document.components.valve")
    assert server.row_counts() == before
    assert server.client.get(f"/rigs/{rig['id']}").json()["latest_version"] == 1


def test_request_shape_errors_name_the_field(server: LiveServer) -> None:
    response = server.client.post("/rigs", json={"document": "a string"}, headers=server.auth)
    assert response.status_code == 422
    error = response.json()["error"]
    assert error == {
        "type": "InputError",
        "message": error["message"],
        "field": "document",
        "details": [{"field": "document", "message": error["message"]}],
        "request_id": response.headers["X-Request-ID"],
    }
    bad_json = server.client.post("/rigs", content=b"{not json",
                                  headers=server.auth | {"content-type": "application/json"})
    assert bad_json.status_code == 422
    assert bad_json.json()["error"]["type"] == "InputError"


def test_writes_need_a_valid_key(server: LiveServer, rig_document: dict) -> None:
    rig_document["name"] = "no-key"
    before = server.row_counts()
    missing = server.anon.post("/rigs", json={"document": rig_document})
    assert missing.status_code == 401
    assert missing.json()["error"]["type"] == "AuthError"
    assert missing.json()["error"]["field"] == "X-API-Key"
    assert missing.headers["www-authenticate"] == "APIKey"
    wrong_secret = server.key[:-4] + ("aaaa" if not server.key.endswith("aaaa") else "bbbb")
    for key in (wrong_secret, "hd_000000000000_nothing", "not-a-key"):
        response = server.client.post("/rigs", json={"document": rig_document},
                                      headers={"X-API-Key": key})
        assert response.status_code == 401, key
        assert response.json()["error"]["message"] == "the API key is not valid"
    # authentication comes before validation: no hint about the body without a key
    assert server.anon.post("/rigs", json={}).status_code == 401
    assert server.anon.put("/rigs/1", json={}).status_code == 401
    assert server.anon.delete("/rigs/1").status_code == 401
    assert server.row_counts() == before


def test_unknown_ids_are_404(server: LiveServer, rig_document: dict) -> None:
    for path in ("/rigs/999999", "/rigs/999999/versions", "/rigs/1/versions/999"):
        response = server.client.get(path)
        assert response.status_code == 404, path
        assert response.json()["error"]["type"] == "NotFoundError"
    rig_document["name"] = "paper002-reference"
    response = server.client.put("/rigs/999999", json={"document": rig_document},
                                 headers=server.auth)
    assert response.status_code == 404
    assert server.client.delete("/rigs/999999", headers=server.auth).status_code == 404
    assert server.client.get("/rigs/0").status_code == 422  # ids start at 1


def test_duplicate_name_and_renaming_are_409(server: LiveServer, rig_document: dict) -> None:
    rig = new_rig(server, "unique-name")
    before = server.row_counts()
    rig_document["name"] = "unique-name"
    duplicate = server.client.post("/rigs", json={"document": rig_document},
                                   headers=server.auth)
    assert duplicate.status_code == 409
    assert duplicate.json()["error"]["field"] == "document.name"
    rig_document["name"] = "another-name"
    rename = server.client.put(f"/rigs/{rig['id']}", json={"document": rig_document},
                               headers=server.auth)
    assert rename.status_code == 409
    assert server.row_counts() == before


def test_list_pages(server: LiveServer) -> None:
    for i in range(3):
        new_rig(server, f"paged-{i}")
    everything = server.client.get("/rigs", params={"limit": 500}).json()
    total = everything["total"]
    assert total == len(everything["items"]) >= 4
    ids = [r["id"] for r in everything["items"]]
    assert ids == sorted(ids)
    page = server.client.get("/rigs", params={"limit": 2, "offset": 1}).json()
    assert page["total"] == total
    assert (page["limit"], page["offset"]) == (2, 1)
    assert [r["id"] for r in page["items"]] == ids[1:3]
    past_end = server.client.get("/rigs", params={"offset": total}).json()
    assert past_end["items"] == [] and past_end["total"] == total
    too_big = server.client.get("/rigs", params={"limit": 501})
    assert too_big.status_code == 422
    assert too_big.json()["error"]["field"] == "limit"
    assert server.client.get("/rigs", params={"offset": -1}).json()["error"]["field"] == "offset"


def test_delete_rig_with_and_without_history(server: LiveServer) -> None:
    plain = new_rig(server, "to-delete")
    response = server.client.delete(f"/rigs/{plain['id']}", headers=server.auth)
    assert response.status_code == 204
    assert server.client.get(f"/rigs/{plain['id']}").status_code == 404
    assert server.client.get(f"/rigs/{plain['id']}/versions/1").status_code == 404

    kept = new_rig(server, "has-history")
    with server.session() as session:
        record_diagnosis(
            session, rig_id=kept["id"], measured_at=datetime(2026, 1, 5, tzinfo=UTC),
            record={"p_A_pa": 7.0e6}, result={"ranking": []}, component="valve",
            probability=0.8, estimates=[ComponentEstimate("valve", 0.8, clearance_m=5e-5)],
        )
    before = server.row_counts()
    refused = server.client.delete(f"/rigs/{kept['id']}", headers=server.auth)
    assert refused.status_code == 409
    assert refused.json()["error"]["type"] == "ConflictError"
    assert server.row_counts() == before


def test_a_text_holding_the_nul_character_is_refused_naming_where(server: LiveServer) -> None:
    """A rig description holding U+0000 was stored on SQLite, a 500 on PostgreSQL, and the
    SQLite store could not then be copied to PostgreSQL (an operator pass)."""
    from sim.rigs import reference_rig_document

    document = reference_rig_document() | {"name": "nul-rig", "description": "bad\u0000text"}
    before = server.row_counts()
    response = server.client.post("/rigs", json={"document": document}, headers=server.auth)
    assert response.status_code == 422, response.text
    assert "document.description" in response.text and "U+0000" in response.text
    assert server.row_counts() == before
