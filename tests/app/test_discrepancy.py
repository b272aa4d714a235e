"""POST /discrepancy: a /simulate export of a rig with a hidden friction effect, end to end."""

from __future__ import annotations

import io
import re
import time
from typing import Any

import numpy as np
import pandas as pd
import pytest

from diagnostics.discrepancy.gap import gap_table
from diagnostics.timeseries import read_series
from sim.rigs import reference_rig_document
from tests.app.live import LiveServer

POLL_TIMEOUT_S = 300.0
#: the hidden effect: pressure-dependent seal friction, k_p [m²]
HIDDEN_KP = 1.5e-5
CONDITIONS = ((2100.0, 40.0), (4200.0, 50.0), (6300.0, 60.0))
#: sensor noise added to the export, σ [SI]: 0.05 bar, 1 mm/s, 0.05 L/min
SIGMA = {"P1": 5e3, "P2": 5e3, "P_pump": 5e3, "P_valve_P": 5e3, "v": 1e-3, "x": 1e-4,
         "Q_meter_B": 8.3e-7, "Q_meter_C": 8.3e-7}
UNITS = {"P1": "Pa", "P2": "Pa", "P_pump": "Pa", "P_valve_P": "Pa", "v": "m/s", "x": "m",
         "Q_meter_B": "m^3/s", "Q_meter_C": "m^3/s"}


def _create(server: LiveServer, name: str, effects: dict[str, Any] | None = None) -> int:
    doc = reference_rig_document() | {"name": name}
    if effects:
        doc["effects"] = effects
    r = server.client.post("/rigs", json={"document": doc}, headers=server.auth)
    assert r.status_code == 201, r.text
    return int(r.json()["id"])


def _export(server: LiveServer, rig_id: int, load: float, temp: float,
            version: int | None = None) -> bytes:
    r = server.client.post("/simulate", json={
        "rig_id": rig_id, "rig_version": version, "timeseries": "parquet", "rtol": 1e-5,
        "condition": {"load": load, "oil_temperature": temp}})
    assert r.status_code == 200, r.text
    return r.content


def _measured(exports: list[bytes], rng: np.random.Generator) -> bytes:
    """What a logger would record: 1 kHz samples of the export plus sensor noise."""
    frames = []
    for (load, temp), content in zip(CONDITIONS, exports, strict=True):
        (rec,) = read_series(content)
        t = np.arange(0.0, rec.t[-1], 1e-3)
        idx = np.clip(np.searchsorted(rec.t, t, side="right") - 1, 0, rec.t.size - 1)
        assert rec.phase is not None
        data: dict[str, Any] = {"record": f"load-{load:.0f}", "t [s]": t, "phase": rec.phase[idx]}
        for c, s in SIGMA.items():
            data[f"{c} [{UNITS[c]}]"] = np.interp(t, rec.t, rec.channels[c]) + rng.normal(
                0.0, s, t.size)
        data["load [N]"] = load
        data["oil_temperature [degC]"] = temp
        frames.append(pd.DataFrame(data))
    return pd.concat(frames).to_csv(index=False).encode()


def _follow(server: LiveServer, job_id: str) -> dict[str, Any]:
    deadline = time.monotonic() + POLL_TIMEOUT_S
    while True:
        body = server.client.get(f"/jobs/{job_id}").json()
        if body["status"] in ("succeeded", "failed"):
            return dict(body)
        if time.monotonic() > deadline:
            raise AssertionError(f"discrepancy job {job_id} stuck at {body['progress']}")
        time.sleep(0.2)


@pytest.fixture(scope="module")
def measured(server: LiveServer) -> bytes:
    hidden = _create(server, "hidden-seal-friction", {"seal_friction_pressure": {
        "parameters": {"k_p": {"value": HIDDEN_KP, "unit": "m^2", "source": "hidden"}}}})
    exports = [_export(server, hidden, load, temp) for load, temp in CONDITIONS]
    return _measured(exports, np.random.default_rng(11))


def test_hidden_friction_is_named_stored_and_the_new_version_matches_the_data(
        server: LiveServer, measured: bytes) -> None:
    rig_id = _create(server, "rig-under-test")
    r = server.client.post("/discrepancy", data={"rig_id": str(rig_id)},
                           files={"file": ("cycles.csv", measured, "text/csv")},
                           headers=server.auth)
    assert r.status_code == 202, r.text
    accepted = r.json()
    assert accepted["records"] == ["load-2100", "load-4200", "load-6300"]
    assert r.headers["location"] == f"/jobs/{accepted['job_id']}"
    job = _follow(server, accepted["job_id"])
    assert job["status"] == "succeeded", job["error"]
    result = job["result"]
    assert result["verdict"] == "named"
    assert [n["name"] for n in result["named"]] == ["seal_friction_pressure"]
    named = result["named"][0]
    assert named["interval"][0] <= HIDDEN_KP <= named["interval"][1]
    assert result["held_out_records"] == ["load-6300"]
    assert result["new_rig_version"] == 2
    assert "stored as version 2 of the rig" in result["html"]
    # the stored version has the element with its fitted parameter
    versions = server.client.get(f"/rigs/{rig_id}/versions").json()["items"]
    doc = next(v for v in versions if v["version"] == 2)["document"]
    kp = doc["effects"]["seal_friction_pressure"]["parameters"]["k_p"]["value"]
    assert kp == pytest.approx(named["value"])
    # /simulate of the new version matches the held-out data within the noise
    (held,) = [rec for rec in read_series(measured) if rec.name == "load-6300"]
    new = read_series(_export(server, rig_id, 6300.0, 60.0, version=2))[0].frame()
    old = read_series(_export(server, rig_id, 6300.0, 60.0, version=1))[0].frame()
    after = {(g.channel, g.region): g.rmse for g in gap_table(held, new, list(SIGMA)[:4])}
    before = {(g.channel, g.region): g.rmse for g in gap_table(held, old, list(SIGMA)[:4])}
    for c in ("P1", "P_pump"):
        assert after[(c, "steady")] < 1.3 * SIGMA[c]
        assert before[(c, "steady")] > 2.0 * SIGMA[c]
    page = server.client.get(f"/jobs/{accepted['job_id']}", params={"format": "html"})
    assert page.status_code == 200
    assert page.headers["content-type"].startswith("text/html")
    assert "seal_friction_pressure" in page.text and "<svg" in page.text
    # self-contained: nothing loaded from elsewhere (no scripts, links, remote sources)
    for forbidden in ("<script", 'src="http', "href=\"http", "url(http"):
        assert forbidden not in page.text
    assert re.findall(r"<link[^>]*>", page.text) == ["<link rel='icon' href='data:,'>"]


def test_records_stored_with_the_rig_are_checked_by_id(server: LiveServer,
                                                       measured: bytes) -> None:
    rig_id = _create(server, "rig-with-stored-cycles")
    r = server.client.post(f"/rigs/{rig_id}/series", data={"name": "cycles"},
                           files={"file": ("cycles.csv", measured, "text/csv")},
                           headers=server.auth)
    assert r.status_code == 201, r.text
    ids = [item["id"] for item in r.json()["items"]]
    # read back with its phases: the workflow needs them to find the strokes
    back = server.client.get(f"/series/{ids[0]}").json()
    (first,) = [rec for rec in read_series(measured) if rec.name == "load-2100"]
    assert first.phase is not None and back["phase"] == first.phase.tolist()
    assert back["condition"] == {"load": 2100.0, "oil_temperature": 40.0}
    other = _create(server, "another-rig")
    before = server.row_counts()
    for data, status, field in (({}, 422, "file"),
                                ({"series_ids": "1,a"}, 422, "series_ids"),
                                ({"series_ids": f"{ids[0]},{ids[0]}"}, 422, "series_ids"),
                                ({"series_ids": "99999"}, 404, "series_ids")):
        r = server.client.post("/discrepancy", data={"rig_id": str(rig_id), **data},
                               headers=server.auth)
        assert r.status_code == status and field in r.text, (data, r.text)
    r = server.client.post("/discrepancy", data={"rig_id": str(other), "series_ids": str(ids[0])},
                           headers=server.auth)
    assert r.status_code == 422 and "another rig" in r.text
    r = server.client.post("/discrepancy", data={"rig_id": str(rig_id), "series_ids": "1"},
                           files={"file": ("x.csv", measured)}, headers=server.auth)
    assert r.status_code == 422 and "series_ids" in r.text
    # a stored record the workflow refuses is named by its series id (the error named the
    # record, which many series share, and the channel 'load': a discrepancy pass)
    ramp = pd.read_csv(io.BytesIO(measured), comment="#")
    ramp = ramp[ramp["record"] == "load-4200"].assign(
        **{"load [N]": lambda f: np.linspace(4200.0, 4250.0, len(f))})
    bad = server.client.post(f"/rigs/{rig_id}/series", data={"name": "ramp"},
                             files={"file": ("ramp.csv", ramp.to_csv(index=False), "text/csv")},
                             headers=server.auth)
    assert bad.status_code == 201, bad.text
    bad_id = bad.json()["items"][0]["id"]
    before = server.row_counts()
    r = server.client.post("/discrepancy", data={
        "rig_id": str(rig_id), "series_ids": f"{ids[0]},{bad_id},{ids[2]}"}, headers=server.auth)
    assert r.status_code == 422 and r.json()["error"]["field"] == "series_ids"
    assert r.json()["error"]["message"].startswith(f"series {bad_id} (record 'load-4200'): ")
    assert server.row_counts() == before
    r = server.client.post("/discrepancy", data={
        "rig_id": str(rig_id), "store": "false", "series_ids": ",".join(map(str, ids))},
        headers=server.auth)
    assert r.status_code == 202, r.text
    assert r.json()["records"] == ["load-2100", "load-4200", "load-6300"]
    # its page asked for before it is there: a 409, not a 422 on a valid format
    early = server.client.get(f"/jobs/{r.json()['job_id']}", params={"format": "html"})
    assert early.status_code == 409 or (early.status_code == 200 and "<html" in early.text)
    job = _follow(server, r.json()["job_id"])
    assert job["status"] == "succeeded", job["error"]
    result = job["result"]
    assert [n["name"] for n in result["named"]] == ["seal_friction_pressure"]
    named = result["named"][0]
    assert named["interval"][0] <= HIDDEN_KP <= named["interval"][1]
    assert result["new_rig_version"] is None
    assert server.row_counts()["rig_versions"] == before["rig_versions"]


def test_bad_files_are_422_naming_the_column_and_start_nothing(server: LiveServer,
                                                               measured: bytes) -> None:
    before = server.row_counts()
    frame = pd.read_csv(io.BytesIO(measured)).rename(columns={"P1 [Pa]": "P1 [furlong]"})
    r = server.client.post("/discrepancy", data={"rig_id": "1"},
                           files={"file": ("x.csv", frame.to_csv(index=False).encode())},
                           headers=server.auth)
    assert r.status_code == 422, r.text
    assert "P1 [furlong]" in r.text
    r = server.client.post("/discrepancy", data={"rig_id": "1", "colour": "red"},
                           files={"file": ("x.csv", measured)}, headers=server.auth)
    assert r.status_code == 422, r.text
    # without the stroke labels the workflow compared a whole record with one stroke
    # (every channel hundreds of σ off, "unexplained"); the phases are read off the
    # position now (a diagnosis of the cycle does the same), and without a position or a
    # speed either it is refused before the job
    no_phase = pd.read_csv(io.BytesIO(measured)).drop(columns=["phase", "x [m]", "v [m/s]"])
    r = server.client.post("/discrepancy", data={"rig_id": "1"},
                           files={"file": ("x.csv", no_phase.to_csv(index=False).encode())},
                           headers=server.auth)
    assert r.status_code == 422 and r.json()["error"]["field"] == "phase", r.text
    # records that do not state their load were simulated at the rig's nominal 2.1 kN
    # (healthy cycles "unexplained"); now refused before the job, naming the column
    no_load = pd.read_csv(io.BytesIO(measured)).drop(columns="load [N]")
    r = server.client.post("/discrepancy", data={"rig_id": "1"},
                           files={"file": ("x.csv", no_load.to_csv(index=False).encode())},
                           headers=server.auth)
    assert r.status_code == 422 and r.json()["error"]["field"] == "load", r.text
    assert "load [N]" in r.json()["error"]["message"]
    r = server.client.post("/discrepancy", data={"rig_id": "999"},
                           files={"file": ("x.csv", measured)}, headers=server.auth)
    assert r.status_code == 404, r.text
    # the OpenAPI example was once three samples of a cycle: accepted, and its job failed;
    # too few usable samples is now a 422 before the job
    excerpt = ("record,t [s],phase,P1 [Pa],P2 [Pa],v [m/s],load [N],oil_temperature [degC]\n"
               "load-2100,0.100,working,1.20e6,1.0e5,0.210,2100,40\n"
               "load-2100,0.101,working,1.21e6,1.0e5,0.211,2100,40\n"
               "load-2100,0.102,working,1.20e6,1.0e5,0.210,2100,40\n")
    jobs = server.client.get("/jobs").json()["total"]
    r = server.client.post("/discrepancy", data={"rig_id": "1"},
                           files={"file": ("x.csv", excerpt.encode())}, headers=server.auth)
    assert r.status_code == 422 and "usable samples" in r.json()["error"]["message"], r.text
    assert r.json()["error"]["field"] == "file"
    assert server.client.get("/jobs").json()["total"] == jobs
    assert server.row_counts() == before



def _bench_csv(effects: dict[str, float] | None, seed: int) -> bytes:
    from diagnostics.discrepancy.synthetic import synthesize_bench
    from diagnostics.pump.csvio import bench_to_frame
    from sim.rigs import reference_rig

    bench = synthesize_bench(reference_rig(), rng=np.random.default_rng(seed), effects=effects)
    frame = bench_to_frame(bench)
    # as a bench writes it: bar, rpm, L/min
    frame = pd.DataFrame({"p_in [bar]": frame["p_in [Pa]"] / 1e5,
                          "p_out [bar]": frame["p_out [Pa]"] / 1e5,
                          "n [rpm]": frame["n [rev/s]"] * 60.0,
                          "theta [degC]": frame["theta [degC]"],
                          "q [L/min]": frame["q [m^3/s]"] * 6e4,
                          "replicate [-]": frame["replicate [-]"]})
    return b"# SIMULATED steady points\n" + frame.to_csv(index=False).encode()


def test_a_bench_table_with_hidden_turbulent_slip_is_named_and_stored(
        server: LiveServer) -> None:
    rig_id = _create(server, "bench-under-test")
    content = _bench_csv({"turbulent_pump_slip": 3e-9}, 21)
    r = server.client.post("/discrepancy", data={"rig_id": str(rig_id)},
                           files={"file": ("bench.csv", content, "text/csv")},
                           headers=server.auth)
    assert r.status_code == 202, r.text
    assert r.json()["records"] == ["bench table"]
    job = _follow(server, r.json()["job_id"])
    assert job["status"] == "succeeded", job["error"]
    result = job["result"]
    assert result["verdict"] == "named", result["message"]
    assert [n["name"] for n in result["named"]] == ["turbulent_pump_slip"]
    # the truth within 3 standard errors of the fitted value (the 95 % interval is ±1.96)
    lo, hi = result["named"][0]["interval"]
    se = (hi - lo) / (2 * 1.96)
    assert abs(result["named"][0]["value"] - 3e-9) <= 3 * se
    assert result["named"][0]["value"] == pytest.approx(3e-9, rel=0.1)
    assert result["lack_of_fit"]["before"]["df_pe"] > 0
    assert result["new_rig_version"] == 2
    versions = server.client.get(f"/rigs/{rig_id}/versions").json()["items"]
    doc = next(v for v in versions if v["version"] == 2)["document"]
    kt = doc["effects"]["turbulent_pump_slip"]["parameters"]["K_t"]["value"]
    assert kt == pytest.approx(result["named"][0]["value"])


def test_bad_bench_tables_are_422_naming_the_column_and_store_nothing(
        server: LiveServer) -> None:
    before = server.row_counts()
    good = _bench_csv(None, 22)
    for bad, column in ((good.replace(b"q [L/min]", b"q [furlong]"), "q [furlong]"),
                        (good.replace(b"theta [degC]", b"temp [degC]"), "theta")):
        r = server.client.post("/discrepancy", data={"rig_id": "1"},
                               files={"file": ("bench.csv", bad, "text/csv")},
                               headers=server.auth)
        assert r.status_code == 422, r.text
        assert r.json()["error"]["field"] == column
    holed = good.decode().splitlines()
    cells = holed[5].split(",")
    cells[1] = "nan"
    holed[5] = ",".join(cells)
    r = server.client.post("/discrepancy", data={"rig_id": "1"},
                           files={"file": ("bench.csv", "\n".join(holed).encode(), "text/csv")},
                           headers=server.auth)
    assert r.status_code == 422, r.text
    assert r.json()["error"]["field"] == "p_out [bar]"
    assert server.row_counts() == before


def test_the_openapi_example_runs_to_an_answer(server: LiveServer) -> None:
    """The upload's example (a steady bench table of the rig's own pump) is a job that
    finishes: nothing missing, so "no effect", and nothing stored."""
    schemas = server.client.get("/openapi.json").json()["components"]["schemas"]
    (body,) = [v for k, v in schemas.items() if "start_discrepancy" in k]
    example = body["properties"]["file"]["examples"][0]
    r = server.client.post("/discrepancy", data={"rig_id": "1", "store": "false"},
                           files={"file": ("bench.csv", example.encode(), "text/csv")},
                           headers=server.auth)
    assert r.status_code == 202, r.text
    result = _follow(server, r.json()["job_id"])["result"]
    assert result["verdict"] == "no effect" and result["new_rig_version"] is None
    # a column map reads a logger's time series, not a bench table; a bad one is named
    for form, field in (({"column_map": '{"q": ["Q_meter_B", "L/min"]}'}, "column_map"),
                        ({"sample_rate": "100"}, "sample_rate")):
        refused = server.client.post("/discrepancy", data={"rig_id": "1"} | form,
                                     files={"file": ("bench.csv", example.encode(), "text/csv")},
                                     headers=server.auth)
        assert refused.status_code == 422 and refused.json()["error"]["field"] == field
