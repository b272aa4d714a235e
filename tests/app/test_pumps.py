"""Pump parameter sets and loss maps through HTTP."""

from __future__ import annotations

from typing import Any

import pytest

from tests.app.conftest import new_rig
from tests.app.live import LiveServer

PARAMETERS: dict[str, Any] = {
    "name": "gear-14.7cc",
    "kind": "parameters",
    "pump": "external gear pump, 14.7 cm³/rev",
    "source": "paper 000, two-temperature method",
    "quantities": {
        "displacement": {"value": 1.47e-5, "unit": "m^3/rev", "description": "derived"},
        "Cs": {"value": 2.1e-9, "unit": "1"},
    },
}
LOSS_MAP: dict[str, Any] = {
    "name": "v32-flow-loss",
    "kind": "loss_map",
    "pump": "variable-displacement pump V32HL56",
    "quantities": {
        "pressure": {"value": [5.0e6, 1.0e7, 1.5e7], "unit": "Pa"},
        "speed": {"value": [100.0, 150.0], "unit": "rad/s"},
        "flow_loss": {"value": [[1e-6, 2e-6], [2e-6, 3e-6], [3e-6, 5e-6]], "unit": "m^3/s"},
    },
}


def test_create_get_list_and_filter(server: LiveServer) -> None:
    rig = new_rig(server, "pump-owner")
    created = server.client.post("/pump-sets", json=PARAMETERS | {"rig_id": rig["id"]},
                                 headers=server.auth)
    assert created.status_code == 201, created.text
    body = created.json()
    assert created.headers["location"] == f"/pump-sets/{body['id']}"
    assert body["quantities"]["Cs"] == {"value": 2.1e-9, "unit": "1", "description": None}
    assert server.client.get(f"/pump-sets/{body['id']}").json() == body
    loss_map = server.client.post("/pump-sets", json=LOSS_MAP, headers=server.auth)
    assert loss_map.status_code == 201, loss_map.text
    assert loss_map.json()["quantities"]["flow_loss"]["value"][2] == [3e-6, 5e-6]
    maps = server.client.get("/pump-sets", params={"kind": "loss_map"}).json()
    assert [p["name"] for p in maps["items"]] == ["v32-flow-loss"] and maps["total"] == 1
    of_rig = server.client.get("/pump-sets", params={"rig_id": rig["id"]}).json()
    assert [p["id"] for p in of_rig["items"]] == [body["id"]]
    page = server.client.get("/pump-sets", params={"limit": 1, "offset": 1}).json()
    assert page["total"] >= 2 and len(page["items"]) == 1


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"quantities": {"m": {"value": [[1.0, 2.0], [3.0]], "unit": "Pa"}}}, "quantities.m.value"),
        ({"quantities": {"m": {"value": 1.0}}}, "quantities.m.unit"),
        ({"quantities": {"m": {"value": 1.0, "unit": ""}}}, "quantities.m.unit"),
        ({"quantities": {"m": {"value": 1.0, "unit": "furlong"}}}, "quantities.m.unit"),
        ({"quantities": {}}, "quantities"),
        ({"quantities": {"2bad": {"value": 1.0, "unit": "1"}}}, "quantities.2bad"),
        ({"kind": "curve"}, "kind"),
        ({"name": ""}, "name"),
    ],
)
def test_invalid_sets_are_422_naming_the_field(
    server: LiveServer, change: dict[str, Any], field: str
) -> None:
    before = server.row_counts()
    response = server.client.post("/pump-sets", json=PARAMETERS | {"name": "x"} | change,
                                  headers=server.auth)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == field
    assert server.row_counts() == before


def test_unknown_rig_name_conflict_and_missing_key(server: LiveServer) -> None:
    before = server.row_counts()
    unknown_rig = server.client.post("/pump-sets", json=PARAMETERS | {"name": "orphan",
                                                                      "rig_id": 999999},
                                     headers=server.auth)
    assert unknown_rig.status_code == 404
    assert unknown_rig.json()["error"]["field"] == "rig_id"
    assert server.anon.post("/pump-sets", json=PARAMETERS | {"name": "nokey"}).status_code == 401
    assert server.row_counts() == before
    server.client.post("/pump-sets", json=PARAMETERS | {"name": "taken"}, headers=server.auth)
    before = server.row_counts()
    taken = server.client.post("/pump-sets", json=PARAMETERS | {"name": "taken"},
                               headers=server.auth)
    assert taken.status_code == 409
    assert taken.json()["error"]["field"] == "name"
    assert server.row_counts() == before


def test_patch_and_delete(server: LiveServer) -> None:
    rig = new_rig(server, "pump-patch")
    body = server.client.post("/pump-sets", json=PARAMETERS | {"name": "patch-me",
                                                               "rig_id": rig["id"]},
                              headers=server.auth).json()
    url = f"/pump-sets/{body['id']}"
    renamed = server.client.patch(url, json={"name": "patched", "rig_id": None},
                                  headers=server.auth).json()
    assert renamed["name"] == "patched" and renamed["rig_id"] is None
    assert renamed["quantities"] == body["quantities"]
    assert server.client.patch(url, json={"pump": None}, headers=server.auth).json()[
        "error"]["field"] == "pump"
    assert server.client.patch(url, json={"rig_id": 999999},
                               headers=server.auth).status_code == 404
    assert server.anon.patch(url, json={"name": "x"}).status_code == 401
    # a negative displacement was stored (a user pass)
    negative = server.client.patch(url, json={"quantities": {"D": {"value": -1.0,
                                                                   "unit": "m^3/rad"}}},
                                   headers=server.auth)
    assert negative.status_code == 422
    assert "quantities.D: must be > 0" in negative.json()["error"]["message"]
    # ... and a negative slip coefficient (a pump maker's pass: Cs = −5 stored)
    slip = server.client.patch(url, json={"quantities": {"Cs": {"value": -5.0, "unit": "1"}}},
                               headers=server.auth)
    assert slip.status_code == 422
    assert "quantities.Cs: must be ≥ 0" in slip.json()["error"]["message"]
    assert server.client.get(url).json() == renamed
    # new quantities without a new source: the old source is kept, marked as describing the
    # set as it was (a bench set's "loss model checked" would otherwise vouch for them)
    replaced = server.client.patch(url, json={"quantities": {"Cs": {"value": 3e-9,
                                                                    "unit": "1"}}},
                                   headers=server.auth).json()
    assert replaced["source"].startswith("paper 000, two-temperature method; quantities "
                                         "replaced by an update")
    renamed = replaced
    assert server.client.delete(url, headers=server.auth).status_code == 204
    for response in (server.client.get(url), server.client.delete(url, headers=server.auth),
                     server.client.patch(url, json={}, headers=server.auth)):
        assert response.status_code == 404


def test_deleting_the_rig_detaches_its_pump_sets(server: LiveServer) -> None:
    rig = new_rig(server, "pump-rig-gone")
    body = server.client.post("/pump-sets", json=PARAMETERS | {"name": "survivor",
                                                               "rig_id": rig["id"]},
                              headers=server.auth).json()
    assert server.client.delete(f"/rigs/{rig['id']}", headers=server.auth).status_code == 204
    assert server.client.get(f"/pump-sets/{body['id']}").json()["rig_id"] is None


def test_a_unit_hydrodiag_does_not_know_is_refused_and_an_old_one_reads_back(
        server: LiveServer) -> None:
    """A quantity in 'furlong' was stored as given; now refused naming it.  A set stored
    before the check reads back as it was written, not as a server error."""
    from app.db.models import PumpSet

    refused = server.client.post("/pump-sets", json={
        "name": "furlongs", "kind": "parameters", "pump": "p",
        "quantities": {"D": {"value": 1.0, "unit": "furlong"}}})
    assert refused.status_code == 422
    assert refused.json()["error"]["field"] == "quantities.D.unit"
    assert "unknown unit 'furlong'" in refused.json()["error"]["message"]
    with server.session() as session:
        old = PumpSet(name="stored-before-the-check", kind="parameters", pump="p",
                      quantities={"D": {"value": 1.0, "unit": "furlong"}})
        session.add(old)
        session.commit()
        old_id = old.id
    back = server.client.get(f"/pump-sets/{old_id}")
    assert back.status_code == 200 and back.json()["quantities"]["D"]["unit"] == "furlong"
