"""GET /rigs/{rig_id}/trends over stored diagnoses."""

from __future__ import annotations

import dataclasses
import math
from datetime import datetime

import numpy as np
import pytest
from scipy import stats

from diagnostics.trend_fit import RESOLUTION_ULPS
from tests.app.conftest import new_rig, simulated_record
from tests.app.live import LiveServer

#: A valve wearing from 36 to 44 µm over three visits a month apart.
VISITS = (("2026-01-05T09:00:00Z", 36e-6), ("2026-02-05T09:00:00Z", 40e-6),
          ("2026-03-05T09:00:00Z", 44e-6))


@pytest.fixture(scope="module")
def wearing_rig(server: LiveServer) -> int:
    rig_id = int(new_rig(server, "trend-rig")["id"])
    for when, cv in VISITS:
        record = simulated_record(server, {"valve.cv": cv}, rig_id=rig_id, measured_at=when)
        response = server.client.post("/diagnose", json={"record": record},
                                      headers=server.auth)
        assert response.status_code == 200, response.text
    return rig_id


def test_three_diagnoses_of_a_wearing_valve_give_a_positive_slope(
    server: LiveServer, wearing_rig: int
) -> None:
    response = server.client.get(f"/rigs/{wearing_rig}/trends")
    assert response.status_code == 200, response.text
    trends = {t["component"]: t for t in response.json()["components"]}
    valve = trends["valve"]
    assert valve["quantity"] == "cv" and valve["unit"] == "m"
    assert [p["measured_at"] for p in valve["points"]] == [when for when, _ in VISITS]
    assert [p["value"] for p in valve["points"]] == pytest.approx([cv for _, cv in VISITS],
                                                                  rel=0.03)
    assert valve["slope"] > 0 and valve["slope_low"] <= valve["slope"] <= valve["slope_high"]
    # 4 µm a month, in m/s
    assert valve["slope"] == pytest.approx(4e-6 / (29.5 * 86400), rel=0.15)
    # the default threshold: 1.6 × the nominal 34 µm
    assert valve["threshold"] == pytest.approx(34e-6 * 4.1 ** (1 / 3))
    # each visit's valve estimate is stated ±6-10 µm: 8 µm over two months is a slope
    # whose 95 % interval reaches zero, no worsening these three visits can show (the
    # slope's sign alone read "worsening" for healthy components, a planner's pass); the
    # earliest crossing the interval allows is still given
    assert valve["slope_low"] < 0 < valve["slope"]
    assert valve["status"] == "not_worsening" and valve["time_left_s"] is None
    assert "no significant worsening" in valve["message"]
    assert 0 < valve["time_left_low_s"] < 10.4e-6 / valve["slope"]
    # the cylinder did not wear: its closed-form clearance stays nominal
    cylinder = trends["cylinder"]
    assert all(p["value"] == pytest.approx(83e-6, rel=0.05) for p in cylinder["points"])
    assert cylinder["status"] != "crossed"


def test_a_long_series_is_thinned_in_the_answer_and_fitted_whole(
        server: LiveServer, wearing_rig: int) -> None:
    whole = server.client.get(f"/rigs/{wearing_rig}/trends", params={"component": "valve"}
                              ).json()["components"][0]
    thin = server.client.get(f"/rigs/{wearing_rig}/trends",
                             params={"component": "valve", "max_points": 2}
                             ).json()["components"][0]
    assert whole["points_total"] == thin["points_total"] == len(whole["points"]) == 3
    # the first and the latest kept; the fit and the forecast are those of all the points
    assert thin["points"] == [whole["points"][0], whole["points"][-1]]
    assert {k: thin[k] for k in ("slope", "time_left_s", "status")} == {
        k: whole[k] for k in ("slope", "time_left_s", "status")}


def test_thinning_keeps_the_ends_and_spaces_the_rest_evenly() -> None:
    from app.services.trends import thinned

    points = list(range(35_000))
    kept = thinned(points, 2000)  # type: ignore[arg-type]
    assert len(kept) == 2000 and kept[0] == 0 and kept[-1] == 34_999
    steps = np.diff(kept)
    assert steps.min() >= 17 and steps.max() <= 18
    assert thinned(points[:5], 2000) == points[:5]  # type: ignore[arg-type]


def test_one_component_with_a_given_threshold(server: LiveServer, wearing_rig: int) -> None:
    body = server.client.get(f"/rigs/{wearing_rig}/trends",
                             params={"component": "valve", "threshold": 42e-6}).json()
    (valve,) = body["components"]
    assert valve["threshold"] == 42e-6 and valve["threshold_source"] == "given"
    assert valve["status"] == "crossed" and valve["time_left_s"] == 0.0


def test_a_window_with_too_few_visits_says_so(server: LiveServer, wearing_rig: int) -> None:
    body = server.client.get(f"/rigs/{wearing_rig}/trends", params={
        "component": "valve", "since": "2026-02-01T00:00:00Z"}).json()
    (valve,) = body["components"]
    assert len(valve["points"]) == 2
    assert valve["status"] == "insufficient_data" and valve["slope"] is None


def test_a_rig_without_history_has_no_trends(server: LiveServer) -> None:
    rig_id = new_rig(server, "trend-empty")["id"]
    assert server.client.get(f"/rigs/{rig_id}/trends").json() == {"rig_id": rig_id,
                                                                  "components": []}


@pytest.mark.parametrize(
    ("params", "field"),
    [({"threshold": 5e-5}, "threshold"), ({"component": "hose"}, "component"),
     ({"component": "valve", "threshold": -1.0}, "threshold"),
     ({"since": "2026-01-01T00:00:00"}, "since"), ({"max_points": 1}, "max_points")],
)
def test_bad_queries_are_422(server: LiveServer, wearing_rig: int, params: dict[str, object],
                             field: str) -> None:
    response = server.client.get(f"/rigs/{wearing_rig}/trends", params=params)
    assert response.status_code == 422
    assert response.json()["error"]["field"] == field


def test_unknown_rig_is_404(server: LiveServer) -> None:
    response = server.client.get("/rigs/31337/trends")
    assert response.status_code == 404


def test_trend_answer_matches_the_reference_computation(server: LiveServer,
                                                        wearing_rig: int) -> None:
    """The answer equals the unbatched one: each point's interval as its stored diagnosis
    states it, and the slope and interval of scipy's Theil–Sen widened by the stated
    uncertainties (the implementation before the trends page was made faster)."""
    body = server.client.get(f"/rigs/{wearing_rig}/trends").json()
    assert {t["component"] for t in body["components"]} >= {"cylinder", "valve"}
    for trend in body["components"]:
        pts = trend["points"]
        for p in pts:
            stored = server.client.get(f"/diagnoses/{p['diagnosis_id']}").json()
            stated = stored["result"]["estimates"][trend["component"]]
            assert (p["low"], p["high"]) == (stated.get("low"), stated.get("high"))
        t = np.array([datetime.fromisoformat(p["measured_at"]).timestamp() for p in pts])
        y = np.array([p["value"] for p in pts])
        ref = stats.theilslopes(y, t, alpha=0.95, method="separate")
        # a change over the span within RESOLUTION_ULPS of the values' last place is 0
        # (healthy visits of one record read their last bit differently)
        floor = RESOLUTION_ULPS * np.finfo(float).eps * float(np.max(np.abs(y)))
        slope, low, high = (0.0 if abs(b) * float(np.ptp(t)) <= floor else float(b)
                            for b in (ref.slope, ref.low_slope, ref.high_slope))
        u = np.array([(p["high"] - p["low"]) / (2 * 1.959963984540054) for p in pts])
        if np.all(u > 0):
            w = 1.0 / u**2
            t_bar = float(np.sum(w * t) / np.sum(w))
            u_b = 1.0 / math.sqrt(float(np.sum(w * (t - t_bar) ** 2)))
            z = float(stats.norm.ppf(0.975))
            low = min(low, slope - z * u_b)
            high = max(high, slope + z * u_b)
        assert trend["slope"] == pytest.approx(slope, rel=1e-12, abs=0.0)
        assert trend["slope_low"] == pytest.approx(low, rel=1e-12, abs=0.0)
        assert trend["slope_high"] == pytest.approx(high, rel=1e-12, abs=0.0)


@pytest.fixture(scope="module")
def seal_rig(server: LiveServer) -> int:
    """Three healthy visits a month apart, then three with the seal at twice its clearance
    (leakage × 8, past the default threshold of 1.6 ×)."""
    rig_id = int(new_rig(server, "seal-trend-rig")["id"])
    for month, factor in ((1, 1.0), (2, 1.0), (3, 1.0), (4, 2.0), (5, 2.0), (6, 2.0)):
        record = simulated_record(server, {"cylinder.cc": 83e-6 * factor}, rig_id=rig_id,
                                  measured_at=f"2026-{month:02d}-05T09:00:00Z")
        response = server.client.post("/diagnose", json={"record": record},
                                      headers=server.auth)
        assert response.status_code == 200, response.text
    return rig_id


def test_a_crossed_threshold_says_when_the_line_crossed_it(server: LiveServer,
                                                           seal_rig: int) -> None:
    """Past the threshold: time left 0 and ``crossing_at`` the date the fitted line
    crossed it — between the last healthy visit and the last visit, not the last visit
    itself (it once was)."""
    trends = {t["component"]: t
              for t in server.client.get(f"/rigs/{seal_rig}/trends").json()["components"]}
    cyl = trends["cylinder"]
    assert cyl["status"] == "crossed" and cyl["time_left_s"] == 0.0
    crossing = datetime.fromisoformat(cyl["crossing_at"])
    assert datetime.fromisoformat("2026-03-05T09:00:00Z") < crossing \
        < datetime.fromisoformat("2026-06-05T09:00:00Z")
    assert "the fitted line crossed it" in cyl["message"]


def test_a_component_no_later_diagnosis_estimates_is_stale(server: LiveServer,
                                                           seal_rig: int) -> None:
    """Every component with points in the healthy months but none in the three worn
    ones (the worn seal's readings reject it alone) is 'stale': it says how many later
    diagnoses gave no estimate and forecasts nothing — not a crossing date from points
    the later history overtook.  The cylinder, estimated on every visit, is not."""
    trends = server.client.get(f"/rigs/{seal_rig}/trends").json()["components"]
    stale = [t for t in trends if t["later_diagnoses"] > 0]
    # the pump: plausible on the healthy visits (a leak at the start of its worn range
    # fits their readings), rejected on the worn seal's
    assert [t["component"] for t in stale] == ["pump"]
    for t in stale:
        last = datetime.fromisoformat(t["points"][-1]["measured_at"])
        assert last < datetime.fromisoformat("2026-04-05T09:00:00Z")
        assert t["later_diagnoses"] == 3 and t["status"] == "stale"
        assert t["time_left_s"] is None and t["crossing_at"] is None
        assert "no " in t["message"] and "3 later diagnosis(es)" in t["message"]
        # what those diagnoses named: "stale" alone read like a fault of a healthy pump
        assert "they named cylinder 3" in t["message"]
    assert {t["component"] for t in trends if t["later_diagnoses"] == 0} == {"cylinder",
                                                                             "valve"}


def test_points_of_a_version_with_other_parameters_are_left_out(server: LiveServer) -> None:
    """A rig diagnosed three times, its document then given a 15 % shorter seal (as
    commissioning would write it), diagnosed three times more: the seal's estimates
    against the older document are a step off the newer ones, so the cylinder's trend
    joins only the latest version's points and says how many it left out and why.  A
    version that changes only the comment keeps every point."""
    from sim.rigs import reference_rig_document

    rig_id = int(new_rig(server, "version-trend-rig")["id"])

    def diagnose(month: int) -> None:
        record = simulated_record(server, {}, rig_id=rig_id,
                                  measured_at=f"2026-{month:02d}-05T09:00:00Z")
        response = server.client.post("/diagnose", json={"record": record},
                                      headers=server.auth)
        assert response.status_code == 200, response.text

    for month in (1, 2, 3):
        diagnose(month)
    same = reference_rig_document() | {"name": "version-trend-rig"}
    response = server.client.put(f"/rigs/{rig_id}", json={"document": same,
                                                          "comment": "comment only"},
                                 headers=server.auth)
    assert response.status_code == 200, response.text
    diagnose(4)
    cyl = server.client.get(f"/rigs/{rig_id}/trends", params={"component": "cylinder"}
                            ).json()["components"][0]
    assert len(cyl["points"]) == 4 and cyl["left_out"] == 0
    shorter = reference_rig_document() | {"name": "version-trend-rig"}
    shorter["components"]["cylinder"]["parameters"]["Lc"]["value"] *= 0.85
    response = server.client.put(f"/rigs/{rig_id}", json={"document": shorter},
                                 headers=server.auth)
    assert response.status_code == 200, response.text
    for month in (5, 6, 7):
        diagnose(month)
    cyl = server.client.get(f"/rigs/{rig_id}/trends", params={"component": "cylinder"}
                            ).json()["components"][0]
    assert [p["rig_version"] for p in cyl["points"]] == [3, 3, 3]
    assert cyl["left_out"] == 4 and cyl["left_out_versions"] == [1, 2]
    assert "4 point(s) of version(s) 1, 2 left out" in cyl["message"]
    # the older versions are told apart by their documents, not compiled: a cache that
    # has only seen the trends holds the latest version alone
    from app.services.rig_cache import RigCache
    from app.services.trends import component_trends

    fresh = RigCache()
    with server.session() as session:
        (again,) = component_trends(session, fresh, rig_id, component="cylinder")
    assert (again.left_out, again.left_out_versions, len(fresh)) == (4, [1, 2], 1)


def test_a_seal_wearing_short_of_its_worn_range_trends_where_it_is(server: LiveServer) -> None:
    """A seal wearing from its document value (83 µm) toward the worn range (91.3 µm),
    three visits a month apart, without flow meters: each stored point is the profile
    from the document's value (source "profile"), its interval holds the truth, and the
    trend rises — not three points at the worn range's start with intervals that exclude
    the seal, a flat line."""
    rig_id = int(new_rig(server, "incipient-trend-rig")["id"])
    visits = (("2026-01-05T09:00:00Z", 84e-6), ("2026-02-05T09:00:00Z", 86.5e-6),
              ("2026-03-05T09:00:00Z", 89e-6))
    for when, cc in visits:
        record = simulated_record(server, {"cylinder.cc": cc}, rig_id=rig_id,
                                  load=4200.0, measured_at=when)
        del record["flow_B"], record["flow_C"]
        response = server.client.post("/diagnose", json={"record": record},
                                      headers=server.auth)
        assert response.status_code == 200, response.text
        est = response.json()["diagnoses"][0]["result"]["estimates"]["cylinder"]
        assert est["source"] == "profile" and est["low"] <= cc <= est["high"]
    cyl = server.client.get(f"/rigs/{rig_id}/trends", params={"component": "cylinder"}
                            ).json()["components"][0]
    assert [p["value"] for p in cyl["points"]] == pytest.approx([cc for _, cc in visits],
                                                                rel=5e-3)
    assert cyl["slope"] == pytest.approx(2.5e-6 / (29.5 * 86400), rel=0.15)


def test_points_of_unexplained_diagnoses_are_left_out(server: LiveServer) -> None:
    """Three healthy visits and a fourth whose piston reads stalled (speed 0 with the pump
    delivering): the model does not explain it, and its closed-form seal gap (all of meter
    B's flow read as leakage) is far past the threshold.  The trend leaves that point out
    and says so, instead of forecasting a crossing from it."""
    rig_id = int(new_rig(server, "unexplained-trend-rig")["id"])
    for month in (1, 2, 3, 4):
        record = simulated_record(server, {}, rig_id=rig_id,
                                  measured_at=f"2026-{month:02d}-05T09:00:00Z")
        if month == 4:
            record["speed_work"] = 0.0
        response = server.client.post("/diagnose", json={"record": record},
                                      headers=server.auth)
        assert response.status_code == 200, response.text
        assert (response.json()["diagnoses"][0]["top"] == "unexplained") == (month == 4)
    stored = server.client.get("/diagnoses", params={"rig_id": rig_id}).json()["items"]
    assert len(stored) == 4
    cyl = server.client.get(f"/rigs/{rig_id}/trends", params={"component": "cylinder"}
                            ).json()["components"][0]
    assert len(cyl["points"]) == 3 and cyl["unexplained"] == 1
    assert all(p["value"] == pytest.approx(83e-6, rel=0.05) for p in cyl["points"])
    assert cyl["status"] == "not_worsening" and cyl["crossing_at"] is None
    assert "1 point(s) of diagnoses the rig model did not explain left out" in cyl["message"]


def _monthly(values: list[float]) -> list:
    """Visits 30 days apart from 2026-01-05, without intervals, p = 0.9 [m]."""
    from datetime import UTC, timedelta

    from app.services.trends import TrendPointOut

    start = datetime(2026, 1, 5, 9, tzinfo=UTC)
    return [TrendPointOut(k + 1, start + timedelta(days=30 * k), 1, value, None, None, 0.9)
            for k, value in enumerate(values)]


def test_a_latest_estimate_past_the_threshold_is_named() -> None:
    """Four visits at 40 µm and a fifth at 60 µm against a 50 µm threshold: the robust
    line stays at 40 µm (not crossed, not worsening), and the message names the last
    estimate past the threshold instead of staying silent about it."""
    from app.services.trends import _trend

    points = _monthly([40e-6, 40e-6, 40e-6, 40e-6, 60e-6])
    trend = _trend("valve", 1, points, 50e-6, "given")
    assert trend.status == "not_worsening"
    assert "the latest estimate, 60 µm (2026-05-05), is past the threshold" in trend.message
    below = _trend("valve", 1, points[:4], 50e-6, "given")
    assert "latest estimate" not in below.message


def test_a_crossed_trend_whose_latest_estimate_is_below_the_threshold_says_so() -> None:
    """Four visits at 60 µm and a fifth at 34 µm against a 50 µm threshold: the robust
    line stays past the threshold ("crossed"), and the message now names the healthy last
    estimate beside it (the status alone read "past the threshold" over a healthy visit;
    a console pass)."""
    from app.services.trends import _trend

    points = _monthly([60e-6, 60e-6, 60e-6, 60e-6, 34e-6])
    trend = _trend("valve", 1, points, 50e-6, "given")
    assert trend.status == "crossed"
    assert "the latest estimate, 34 µm (2026-05-05), is below the threshold" in trend.message
    past = _trend("valve", 1, points[:4], 50e-6, "given")
    assert past.status == "crossed" and "latest estimate" not in past.message


def test_a_status_leaning_on_an_unlikely_components_estimate_says_so() -> None:
    """A pump Cs stored from a diagnosis that gave the pump p = 0.002 (the valve explained
    the readings) read "the latest estimate … is past the threshold" as a plain fact."""
    from datetime import UTC

    from app.services.trends import UNLIKELY, TrendPointOut, _if_blamed

    when = datetime(2026, 11, 2, tzinfo=UTC)
    unlikely = TrendPointOut(63, when, 1, 1.1e-7, 1.0e-7, 1.2e-7, 0.002)
    note = _if_blamed("pump", unlikely)
    assert "holds if the pump is the worn component" in note and "(63)" in note
    assert "probability 0.002" in note
    likely = TrendPointOut(64, when, 1, 1.1e-7, 1.0e-7, 1.2e-7, UNLIKELY)
    assert _if_blamed("pump", likely) == ""
    assert _if_blamed("pump", TrendPointOut(65, when, 1, 1.1e-7, None, None, None)) == ""


def test_a_summary_table_qualifies_a_status_that_leans_on_an_unlikely_estimate() -> None:
    """The CLI's summary read a healthy pump "crossed", 0 days left, from Cs estimates of
    diagnoses that named the valve (p 0.16-0.33), where only the HTML said so (a CLI
    pass): the status is qualified with the last point's probability."""
    from app.services.trends import _trend, status_text

    points = _monthly([2e-8, 4e-8, 6e-8, 8e-8, 1e-7])
    crossed = _trend("pump", 1, points, 9e-8, "given")
    assert crossed.status == "crossed" and status_text(crossed) == "crossed"  # p 0.9
    unlikely = [dataclasses.replace(p, probability=0.2) for p in points]
    blamed = _trend("pump", 1, unlikely, 9e-8, "given")
    assert blamed.status == "crossed"
    assert status_text(blamed) == "crossed if it is the worn one (p 0.2)"


def _points(values: list[float], *, u: float = 1e-6, probability: float = 0.9,
            start: datetime | None = None, days: float = 7.0) -> list:
    from datetime import UTC, timedelta

    from app.services.trends import TrendPointOut

    start = start or datetime(2026, 1, 5, 9, tzinfo=UTC)
    return [TrendPointOut(k + 1, start + timedelta(days=days * k), 1, v, v - 1.96 * u,
                          v + 1.96 * u, probability) for k, v in enumerate(values)]


def test_a_spool_that_stepped_is_a_step_with_its_date_not_wear() -> None:
    """A spool at 34 µm for 20 weekly visits, then 46 µm for 20 (a contamination event):
    the straight line read "worsening, reaches 54.4 µm in 78 days" (a planner's pass); the
    trend names the step and its date, and forecasts from the visits after it."""
    from app.services.trends import _trend

    rng = np.random.default_rng(6)
    values = [34e-6 + rng.normal(0, 1e-6) for _ in range(20)] + \
             [46e-6 + rng.normal(0, 1e-6) for _ in range(20)]
    trend = _trend("valve", 1, _points(values), 34e-6 * 4.1 ** (1 / 3), "default")
    assert trend.step_at is not None and trend.step_size == pytest.approx(12e-6, rel=0.15)
    # between the 20th visit (day 133) and the 21st (day 140)
    assert trend.points[19].measured_at < trend.step_at < trend.points[20].measured_at
    assert trend.points_fitted == 20 and trend.status == "not_worsening"
    assert f"around {trend.step_at:%Y-%m-%d}" in trend.message
    assert trend.message.startswith("a step of +1")


def test_a_pump_estimate_of_an_unlikely_pump_past_the_threshold_says_so() -> None:
    """The qualifier "if the pump is the worn one" never reached the message: its text
    lacked the f prefix and printed "{_if_blamed(component, last)}" (a planner's pass)."""
    from app.services.trends import _trend

    points = _points([1.0e-7, 1.0e-7, 1.0e-7, 1.0e-7, 1.3e-7], u=2e-9, probability=0.39)
    trend = _trend("pump", 1, points, 1.2e-7, "given")
    assert "{" not in trend.message
    assert "holds if the pump is the worn component" in trend.message
    assert "probability 0.39" in trend.message


def test_later_unexplained_diagnoses_are_named_as_such() -> None:
    """Three records with the load's sign slipped were stored unexplained after a seal's
    history: the stale message said "no cc estimate in the 3 later diagnoses", but their
    estimates existed and were left out as unexplained."""
    from datetime import UTC

    from app.services.trends import _trend

    points = _points([83e-6 + 1e-6 * k for k in range(10)])
    later = (3, datetime(2026, 4, 1, tzinfo=UTC), {"unexplained": 3})
    trend = _trend("cylinder", 1, points, 132.8e-6, "default", later)
    assert trend.status == "stale"
    assert "were not explained by the rig model" in trend.message
    assert "no cc estimate" not in trend.message


def test_a_forecast_date_already_past_is_said() -> None:
    """"13.6 days left, around 2026-10-12" was shown on 2026-11-29: the time left counts
    from the last visit, which the message now names when its date has passed."""
    from datetime import UTC

    from app.services.trends import _trend

    points = _points([83e-6 + 3e-6 * k for k in range(10)],
                     start=datetime(2025, 1, 6, tzinfo=UTC))
    trend = _trend("cylinder", 1, points, 132.8e-6, "default")
    assert trend.status == "worsening" and trend.crossing_at is not None
    assert "is already past: diagnose the rig again" in trend.message
    assert f"counted from the last visit ({points[-1].measured_at:%Y-%m-%d})" in trend.message
    # a view `until` an earlier time says nothing of it (later diagnoses lie outside)
    past = _trend("cylinder", 1, points, 132.8e-6, "default", current=False)
    assert "diagnose the rig again" not in past.message


def test_a_clearance_threshold_in_micrometres_is_refused(server: LiveServer) -> None:
    """threshold=130 (µm meant) answered "reaches 130 m in 7.29e+08 days"."""
    response = server.client.get("/rigs/1/trends",
                                 params={"component": "cylinder", "threshold": 130})
    assert response.status_code == 422
    error = response.json()["error"]
    assert error["field"] == "threshold" and "unit slip? 130 µm is 0.00013" in error["message"]
    mm = server.client.get("/rigs/1/trends", params={"component": "valve", "threshold": 0.06})
    assert "0.06 mm is 6e-05" in mm.json()["error"]["message"]


def test_visits_seconds_apart_forecast_nothing() -> None:
    """26 records posted without ``measured_at`` are stamped with their requests' times:
    the trend read "cc reaches 132.8 µm in 0.0637 s" (a reliability engineer's pass).
    Visits spanning less than an hour give no rate; a day's span does."""
    from app.services.trends import MIN_SPAN_S, _trend

    values = [83e-6 + 1.6e-6 * k for k in range(26)]
    seconds = _points(values, days=0.05 / 86400.0)
    trend = _trend("cylinder", 1, seconds, 132.8e-6, "default")
    assert trend.status == "insufficient_data" and trend.time_left_s is None
    assert trend.slope is None and trend.crossing_at is None
    assert trend.step_at is None and trend.step_size is None and trend.points_fitted == 26
    assert "the 26 visits span 1.25 s" in trend.message
    assert "without measured_at" in trend.message
    hours = _points(values, days=2 * MIN_SPAN_S / 25 / 86400.0)
    assert _trend("cylinder", 1, hours, 132.8e-6, "default").status == "worsening"


def test_a_worsening_pump_trend_names_the_oil_temperature() -> None:
    """A healthy model pump's Cs rose as the oil cooled (55 → 35 °C) and read "worsening,
    656 days" with the caveat only in the documentation (a reliability engineer's pass);
    a clearance's trend says nothing of it."""
    from app.services.trends import _trend

    rising = [1.3e-8 * (1 + 0.05 * k) for k in range(20)]
    pump = _trend("pump", 1, _points(rising, u=2e-10), 9.8e-8, "default")
    assert pump.status == "worsening"
    assert "compare records taken at one oil temperature" in pump.message
    seal = _trend("cylinder", 1, _points([83e-6 + 1e-6 * k for k in range(20)]), 132.8e-6,
                  "default")
    assert seal.status == "worsening" and "oil temperature" not in seal.message
