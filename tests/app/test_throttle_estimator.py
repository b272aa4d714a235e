"""The throttle-table clearance estimator wired into the service (diagnostics.throttle)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from app.services.throttle_estimator import ThrottleClearanceEstimator
from sim.errors import InputError
from sim.rigs import Condition, reference_rig, reference_rig_document
from sim.steady import steady_cycle
from tests.app.live import LiveServer, live_server, store_settings


@pytest.fixture(scope="module")
def estimating_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    with live_server(store_settings(tmp_path_factory.mktemp("estimating")),
                     estimator=ThrottleClearanceEstimator()) as live:
        yield live


def test_the_nominal_leakage_gives_the_nominal_clearance() -> None:
    """Round trip through the forward model: the rig's own leak → the rig's own clearance."""
    rig = reference_rig()
    estimator = ThrottleClearanceEstimator()
    for back_pressure, temperature in ((1.0e6, 40.0), (2.0e6, 55.0)):
        condition = Condition(load=back_pressure * rig.values()["cylinder.A2"],
                              oil_temperature=temperature)
        working = steady_cycle(rig, None, condition).working
        for component, flow, clearance in (
            ("cylinder", working["Q_cyl_leak"], rig.base["cylinder.cc"]),
            ("valve", working["Q_valve_leak"], rig.base["valve.cv"]),
        ):
            found = estimator(rig_document=reference_rig_document(), component=component,
                              bypass_flow_m3s=flow, back_pressure_pa=back_pressure,
                              temperature_c=temperature)
            assert found == pytest.approx(clearance, rel=1e-6), (component, back_pressure)


def test_an_unknown_component_is_refused() -> None:
    with pytest.raises(Exception, match="no leakage law") as info:
        ThrottleClearanceEstimator()(rig_document=reference_rig_document(), component="hose",
                                     bypass_flow_m3s=1e-5, back_pressure_pa=1e6,
                                     temperature_c=40.0)
    assert getattr(info.value, "field", None) == "component"


def test_a_temperature_the_rig_model_does_not_cover_names_the_table_s_field() -> None:
    """The estimator's 422 named ``condition.oil_temperature``, a field a table has not."""
    with pytest.raises(InputError, match="≤ 150") as info:
        ThrottleClearanceEstimator()(rig_document=reference_rig_document(), component="valve",
                                     bypass_flow_m3s=1e-5, back_pressure_pa=1e6,
                                     temperature_c=180.0)
    assert info.value.field == "temperature_c"


def test_the_preloaded_tables_get_their_missing_clearance(estimating_server: LiveServer) -> None:
    tables = estimating_server.client.get("/rigs/1/calibrations").json()["items"]
    by_throttle = {t["throttle"]: t for t in tables}
    valve, cylinder = by_throttle["I"], by_throttle["H"]
    # published values stay as published
    assert [p["clearance_m"] for p in valve["points"]] == [34e-6, 37e-6, 49e-6, 62e-6, 73e-6]
    assert [p["clearance_origin"] for p in cylinder["points"]] == ["given"] * 4 + ["computed"]
    last = cylinder["points"][-1]["clearance_m"]
    # Q ∝ c³ from the closed row (83 µm at 1.8e-5 m³/s), within the Couette correction
    assert 139e-6 < last == pytest.approx(83e-6 * (1.05e-4 / 1.8e-5) ** (1 / 3), rel=0.03)
    assert cylinder["curve"]["opening_turns"] == [0.0, 0.5, 1.0, 1.5, 2.0]


def test_a_new_table_gets_its_clearance_column(estimating_server: LiveServer) -> None:
    table: dict[str, Any] = {
        "throttle": "I", "component": "valve", "back_pressure_pa": 2.0e6,
        "temperature_c": 50.0,
        "points": [{"opening_turns": t, "bypass_flow_m3s": q}
                   for t, q in ((0.0, 1.2e-5), (1.0, 3.0e-5), (2.0, 9.0e-5))],
    }
    response = estimating_server.client.post("/rigs/1/calibrations", json=table,
                                             headers=estimating_server.auth)
    assert response.status_code == 201, response.text
    points = response.json()["points"]
    assert [p["clearance_origin"] for p in points] == ["computed"] * 3
    clearances = [p["clearance_m"] for p in points]
    # the spool law has no Couette term: exactly the cube rule between rows
    assert clearances[1] / clearances[0] == pytest.approx((3.0e-5 / 1.2e-5) ** (1 / 3))
    assert clearances[2] / clearances[0] == pytest.approx((9.0e-5 / 1.2e-5) ** (1 / 3))


def test_a_table_for_a_component_without_a_law_stores_nothing(
    estimating_server: LiveServer,
) -> None:
    before = estimating_server.row_counts()
    response = estimating_server.client.post("/rigs/1/calibrations", headers=estimating_server.auth,
                                             json={"throttle": "Z", "component": "hose",
                                                   "back_pressure_pa": 1e6, "temperature_c": 40.0,
                                                   "points": [
                                                       {"opening_turns": 0, "bypass_flow_m3s": 1e-5},
                                                       {"opening_turns": 1, "bypass_flow_m3s": 2e-5}]})
    assert response.status_code == 422
    assert response.json()["error"]["field"] == "component"
    assert estimating_server.row_counts() == before


def _count(server: LiveServer) -> int:
    return int(server.client.get("/rigs/1/calibrations").json()["total"])


def test_unit_slips_and_a_stalled_piston_are_refused_and_store_nothing(
        estimating_server: LiveServer) -> None:
    """A technician's pass stored flows typed in l/min (1.3-1.6 mm "clearances" on a rig
    whose pump delivers 28 l/min), a 7.3 mm clearance, and a table at 80 bar, where the
    piston stalls with the relief open."""
    before = _count(estimating_server)
    table = {"throttle": "X", "component": "valve", "back_pressure_pa": 1.0e6,
             "temperature_c": 40.0}
    lpm = [{"opening_turns": 0.0, "bypass_flow_m3s": 0.520},
           {"opening_turns": 1.0, "bypass_flow_m3s": 0.745}]
    refused = estimating_server.client.post("/rigs/1/calibrations", json=table | {
        "points": lpm}, headers=estimating_server.auth)
    assert refused.status_code == 422, refused.text
    error = refused.json()["error"]
    assert error["field"] == "points[0].bypass_flow_m3s"
    assert "more than the rig's pump delivers" in error["message"]
    assert "28 l/min)" in error["message"] and "(3.12e+04 l/min)" in error["message"]
    wide = [{"opening_turns": 0.0, "bypass_flow_m3s": 8.6e-6, "clearance_m": 34e-6},
            {"opening_turns": 1.0, "bypass_flow_m3s": 2.7e-5, "clearance_m": 7.3e-3}]
    refused = estimating_server.client.post("/rigs/1/calibrations", json=table | {
        "points": wide}, headers=estimating_server.auth)
    assert refused.status_code == 422
    assert refused.json()["error"]["field"] == "points[1].clearance_m"
    stalled = estimating_server.client.post("/rigs/1/calibrations", json=table | {
        "component": "cylinder", "back_pressure_pa": 8.0e6,
        "points": [{"opening_turns": 0.0, "bypass_flow_m3s": 1.8e-5},
                   {"opening_turns": 1.0, "bypass_flow_m3s": 7.0e-5}]},
        headers=estimating_server.auth)
    assert stalled.status_code == 422
    error = stalled.json()["error"]
    assert error["field"] == "back_pressure_pa" and "does not move" in error["message"]
    bar_as_pa = estimating_server.client.post("/rigs/1/calibrations", json=table | {
        "back_pressure_pa": 10.0, "points": [{"opening_turns": 0.0, "bypass_flow_m3s": 8.6e-6},
                                             {"opening_turns": 1.0, "bypass_flow_m3s": 2.7e-5}]},
        headers=estimating_server.auth)
    assert bar_as_pa.status_code == 422
    assert bar_as_pa.json()["error"]["field"] == "back_pressure_pa"
    assert _count(estimating_server) == before


@pytest.mark.parametrize(("change", "field", "words"), [
    ({"points": [{"opening_turns": 0.0, "bypass_flow_m3s": 0.516},
                 {"opening_turns": 1.0, "bypass_flow_m3s": 0.78}]},
     "points[0].bypass_flow_m3s", "more than the rig's pump delivers"),
    ({"back_pressure_pa": 10.0}, "back_pressure_pa", "it is in Pa"),
    ({"back_pressure_pa": 1.0e8}, "back_pressure_pa", "does not move"),
    ({"component": "pump"}, "component", "no leakage law"),
    ({"temperature_c": 150.5}, "temperature_c", "150"),
])
def test_a_table_with_every_clearance_given_is_checked_as_well(
        estimating_server: LiveServer, change: dict[str, Any], field: str, words: str) -> None:
    """With ``clearance_m`` on every row no check ran: flows in l/min, 10 "Pa", 1000 bar,
    component pump and 180 °C were all stored (a technician's pass); the same tables
    without clearances were refused.  Now both are, and the temperature's 422 names the
    table's field (it named ``condition.oil_temperature``)."""
    before = _count(estimating_server)
    given = [{"opening_turns": 0.0, "bypass_flow_m3s": 8.6e-6, "clearance_m": 34e-6},
             {"opening_turns": 1.0, "bypass_flow_m3s": 1.3e-5, "clearance_m": 37e-6}]
    table = {"throttle": "G", "component": "valve", "back_pressure_pa": 1.0e6,
             "temperature_c": 40.0, "points": given}
    if "points" in change:
        change = {"points": [row | c for row, c in zip(given, change["points"], strict=True)]}
    refused = estimating_server.client.post("/rigs/1/calibrations", json=table | change,
                                            headers=estimating_server.auth)
    assert refused.status_code == 422, refused.text
    error = refused.json()["error"]
    assert error["field"] == field and words in error["message"], error
    assert _count(estimating_server) == before
    # a throttle opens ten turns at most, as the rig model's throttle: degrees are refused
    degrees = [row | {"opening_turns": turns} for row, turns in zip(given, (0.0, 45.0),
                                                                        strict=True)]
    refused = estimating_server.client.post("/rigs/1/calibrations", json=table | {
        "points": degrees}, headers=estimating_server.auth)
    assert refused.status_code == 422 and refused.json()["error"]["field"] == (
        "points[1].opening_turns")


def _rig_whose_seal_will_shorten(server: LiveServer, name: str
                                 ) -> tuple[str, Callable[[], None]]:
    """A new copy of the reference rig: its tables' URL, and a call that stores a second
    version with the piston seal length 0.0105 m (the document's 0.01231)."""
    import copy

    from sim.rigs import reference_rig_document

    document = reference_rig_document() | {"name": name}
    rig = server.client.post("/rigs", json={"document": document}, headers=server.auth).json()

    def shorten() -> None:
        shorter = copy.deepcopy(document)
        shorter["components"]["cylinder"]["parameters"]["Lc"]["value"] = 0.0105
        assert server.client.put(f"/rigs/{rig['id']}", json={"document": shorter},
                                 headers=server.auth).status_code == 200

    return f"/rigs/{rig['id']}/calibrations", shorten


def test_computed_clearances_of_an_older_rig_version_are_stale_until_updated(
        estimating_server: LiveServer) -> None:
    """A new rig version with a 15 % shorter seal left a table's computed clearances at the
    old document's values (5 % high) and an empty PATCH changed nothing (a technician's
    pass): the table says it is stale and an empty PATCH computes it again, by the
    laminar law about (L'/L)^(1/3) lower."""
    server = estimating_server
    url, shorten = _rig_whose_seal_will_shorten(server, "throttled-rig")
    table = {"throttle": "H", "component": "cylinder", "back_pressure_pa": 1.0e6,
             "temperature_c": 40.0,
             "points": [{"opening_turns": 0.0, "bypass_flow_m3s": 1.8e-5},
                        {"opening_turns": 1.0, "bypass_flow_m3s": 7.0e-5}]}
    created = server.client.post(url, json=table, headers=server.auth).json()
    assert created["rig_version"] == 1 and created["stale"] is False
    shorten()
    read = server.client.get(f"{url}/{created['id']}").json()
    assert read["stale"] is True and read["rig_version"] == 1
    assert read["points"] == created["points"]
    listed = server.client.get(url).json()["items"]
    assert [t["stale"] for t in listed] == [True]
    assert server.client.get(f"{url}/{created['id']}/clearance",
                             params={"opening_turns": 0.5}).json()["stale"] is True
    fresh = server.client.patch(f"{url}/{created['id']}", json={},
                                headers=server.auth).json()
    assert fresh["stale"] is False and fresh["rig_version"] == 2
    for old, new in zip(created["points"], fresh["points"], strict=True):
        assert new["clearance_m"] / old["clearance_m"] == pytest.approx(
            (0.0105 / 0.01231) ** (1 / 3), rel=0.01)


def test_a_stale_table_whose_recomputed_rows_fall_below_its_given_ones_says_why(
        estimating_server: LiveServer) -> None:
    """The preloaded paper table (four given rows, one computed) after a version with a
    shorter seal: its empty PATCH was refused naming `points[4].clearance_m`, a row the
    user never sent (a check of the technician's fix); now the refusal says what happened
    and what to send."""
    server = estimating_server
    url, shorten = _rig_whose_seal_will_shorten(server, "paper-table-rig")
    paper = {"throttle": "H", "component": "cylinder", "back_pressure_pa": 1.0e6,
             "temperature_c": 40.0,
             "points": [{"opening_turns": 0.0, "bypass_flow_m3s": 1.8e-5, "clearance_m": 83e-6},
                        {"opening_turns": 0.5, "bypass_flow_m3s": 3.5e-5, "clearance_m": 103e-6},
                        {"opening_turns": 1.0, "bypass_flow_m3s": 7.0e-5, "clearance_m": 123e-6},
                        {"opening_turns": 1.5, "bypass_flow_m3s": 8.2e-5, "clearance_m": 139e-6},
                        {"opening_turns": 2.0, "bypass_flow_m3s": 1.05e-4}]}
    table = server.client.post(url, json=paper, headers=server.auth).json()
    shorten()
    refused = server.client.patch(f"{url}/{table['id']}", json={}, headers=server.auth)
    assert refused.status_code == 422
    error = refused.json()["error"]
    assert error["field"] == "points" and "send `points` again" in error["message"]
    assert server.client.get(f"{url}/{table['id']}").json()["points"] == table["points"]
    # a refusal of its own (bar typed as Pa) keeps its field and message
    slip = server.client.patch(f"{url}/{table['id']}", json={"back_pressure_pa": 10.0},
                               headers=server.auth)
    assert slip.status_code == 422 and slip.json()["error"]["field"] == "back_pressure_pa"
