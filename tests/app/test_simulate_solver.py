"""POST /simulate's solver over HTTP: noise-accurate default, sampling grid, every accepted
tolerance runs (issue 16 item 3), solver limits answered 422 with the reason (issue 17)."""

from __future__ import annotations

import io
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from app.settings import Settings
from sim.cycle import run_cycle
from sim.errors import InputError, ParameterError
from sim.rigs import reference_rig
from tests.app.live import LiveServer, live_server, store_settings

SCENARIO: dict[str, Any] = {"rig_id": 1, "condition": {"load": 6300.0, "oil_temperature": 40.0}}


def test_default_is_noise_accurate_and_reports_its_error(server: LiveServer) -> None:
    body = server.client.post("/simulate", json=SCENARIO).json()
    solver = body["solver"]
    assert solver["method"] == "rodas4"
    assert solver["sigma"]["v"] == 3.2e-4 and solver["sigma"]["P_pump"] == 25e3
    assert solver["sigma"]["Q_meter_B"] == 2.33e-6
    assert solver["target_sigma"]["v"] == 0.3 and solver["target_sigma"]["Q_meter_B"] == 0.1
    for name, err in solver["error_sigma"].items():
        assert 0.0 <= err <= solver["target_sigma"][name]
    assert body["completed"] == {"working": True, "return": True}


def test_csv_on_a_1khz_grid(server: LiveServer) -> None:
    response = server.client.post("/simulate", json=SCENARIO | {"timeseries": "csv",
                                                                "sample_rate": 1000.0})
    assert response.status_code == 200, response.text
    header = dict(line[2:].split(" = ", 1) for line in response.text.splitlines()
                  if line.startswith("# "))
    assert json.loads(header["solver"])["method"] == "rodas4"
    frame = pd.read_csv(io.StringIO(response.text), comment="#")
    t = frame["t [s]"].to_numpy()
    np.testing.assert_allclose(np.diff(t), 1e-3, rtol=0, atol=1e-12)
    assert t[0] == 0.0
    assert list(frame["phase"].unique()) == ["working", "return"]
    # the cycle's end: the return phase's last sample lies before the reported duration
    summary = json.loads(header["summary"])
    total = summary["working.duration [s]"] + summary["return.duration [s]"]
    assert total - 1e-3 <= t[-1] <= total


@pytest.mark.parametrize("rtol", [1e-7, 3e-7, 5e-8])
def test_every_accepted_tolerance_runs(server: LiveServer, rtol: float) -> None:
    response = server.client.post("/simulate", json=SCENARIO | {"rtol": rtol})
    assert response.status_code == 200, response.text
    assert response.json()["solver"]["rtol"] == rtol


def test_sampling_asked_of_ros2_is_422(server: LiveServer) -> None:
    response = server.client.post("/simulate", json=SCENARIO | {"solver": "ros2",
                                                                "sample_rate": 1000.0})
    assert response.status_code == 422
    assert response.json()["error"]["field"] == "sample_rate"


def test_noise_fields_are_validated(server: LiveServer) -> None:
    response = server.client.post("/simulate", json=SCENARIO | {"noise": {"v": -1.0}})
    assert response.status_code == 422


@pytest.fixture(scope="module")
def limited(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    settings = store_settings(Path(tmp_path_factory.mktemp("limited")), sim_max_steps=3000,
                               sim_wall_clock=5.0, sim_max_rows=2000)
    with live_server(settings) as live:
        yield live


def test_a_run_past_the_step_limit_is_422_with_the_reason(limited: LiveServer) -> None:
    before = limited.row_counts()
    response = limited.client.post("/simulate", json=SCENARIO | {"solver": "ros2",
                                                                 "rtol": 1e-7})
    assert response.status_code == 422, response.text
    error = response.json()["error"]
    assert error["field"] == "rtol"
    assert "step limit of 3000 steps" in error["message"] and "t = " in error["message"]
    assert limited.row_counts() == before
    # the noise-accurate default fits (a few hundred steps a phase on the summary's grid)
    ok = limited.client.post("/simulate", json=SCENARIO)
    assert ok.status_code == 200, ok.text


def test_the_settings_document_their_solver_limits() -> None:
    settings = Settings(data_dir=Path("unused"))
    assert settings.sim_max_steps == 2_000_000
    assert settings.sim_max_time == 600.0 and settings.sim_wall_clock == 10.0
    assert settings.sim_max_rows == 1_000_000


def test_a_time_series_past_the_row_limit_is_422_before_the_run(
        server: LiveServer, limited: LiveServer) -> None:
    """2.9 M rows of JSON killed the worker mid-answer, the connection dropped without a
    word (an edge pass): the rows a grid would have (the steady path's stroke times × the
    rate) are checked before the run, a JSON series at most 100,000 of them."""
    steady = server.client.post("/simulate", json=SCENARIO | {"method": "steady"}).json()
    span = steady["summary"]["working.duration [s]"] + steady["summary"]["return.duration [s]"]
    refused = server.client.post("/simulate", json=SCENARIO | {
        "sample_rate": 100_000.0, "timeseries": "json"})
    assert refused.status_code == 422, refused.text
    error = refused.json()["error"]
    assert error["field"] == "sample_rate" and "at most 100,000" in error["message"]
    said = float(error["message"].split("about ")[1].split(" rows")[0].replace(",", ""))
    assert said == pytest.approx(span * 100_000.0, rel=1e-6)
    # the setting bounds CSV and Parquet: 1 kHz is ~4,400 rows, past 2,000
    csv = limited.client.post("/simulate", json=SCENARIO | {"sample_rate": 1000.0,
                                                            "timeseries": "csv"})
    assert csv.status_code == 422 and "HYDRODIAG_SIM_MAX_ROWS" in csv.text
    fine = limited.client.post("/simulate", json=SCENARIO | {"sample_rate": 200.0,
                                                             "timeseries": "csv"})
    assert fine.status_code == 200, fine.text
    assert 2 < fine.text.count("\n") < 2000


def test_a_sample_rate_below_one_hertz_is_refused_naming_it(server: LiveServer) -> None:
    # found by the fuzzer: 5e-324 Hz left the phases without samples and answered 500
    for rate in (5e-324, 0.5):
        r = server.client.post("/simulate", json={"rig_id": 1, "sample_rate": rate})
        assert r.status_code == 422, r.text
        assert r.json()["error"]["field"] == "sample_rate"
    with pytest.raises(ParameterError) as exc:
        run_cycle(reference_rig(), method="rodas4", sample_rate=0.5)
    assert exc.value.field == "sample_rate"


def test_errors_name_what_the_request_sent(server: LiveServer) -> None:
    """A noise target too tight was blamed on ``rtol`` and a named fault scaled past a
    bound on ``overrides.cylinder.cc`` "with the overrides given", neither sent (an edge
    pass): the target and the fault are named."""
    tight = server.client.post("/simulate", json=SCENARIO | {"noise": {"v": 1e-12}})
    assert tight.status_code == 422, tight.text
    error = tight.json()["error"]
    assert error["field"] == "noise.v" and "noise.v" in error["message"]
    from sim.rigs import reference_rig_document

    document = reference_rig_document() | {"name": "edge-max-clear-cc"}
    document["components"]["cylinder"]["parameters"]["cc"]["value"] = 2e-3  # its bound
    rig = server.client.post("/rigs", json={"document": document}, headers=server.auth)
    assert rig.status_code == 201, rig.text
    rig_id = rig.json()["id"]
    scaled = server.client.post("/simulate", json={"rig_id": rig_id, "fault": "worn_piston",
                                                   "method": "steady"})
    assert scaled.status_code == 422, scaled.text
    error = scaled.json()["error"]
    assert error["field"] == "fault" and "worn_piston" in error["message"]
    assert "with the overrides given" not in error["message"]


def test_a_stalled_strokes_rows_are_counted_to_its_stall_guard() -> None:
    """A stalled stroke runs to its stall guard (20× its stroke time at the pump's flow),
    not to the 600 s time limit: counted to the limit, a 2 kHz run was refused as 1.2 M rows
    where it has 91 k (a verification pass)."""
    from app.schemas.simulate import SimulateRequest
    from app.services.simulation import _check_grid
    from sim.cycle import phase_params, stall_guard
    from sim.rigs import Condition, reference_rig
    from sim.steady import steady_cycle

    rig = reference_rig()
    stalled = Condition(load=20_000.0, oil_temperature=40.0)  # past the relief's 14.7 kN
    steady = steady_cycle(rig, {}, stalled)
    assert not steady.working.completed
    guard = stall_guard(rig, phase_params(rig, "working", {}, stalled), phase="working")
    request = SimulateRequest.model_validate({"rig_id": 1, "sample_rate": 1000.0,
                                              "timeseries": "json"})
    _check_grid(rig, {}, stalled, request, 1_000_000, None)  # ~50 k rows: allowed
    fast = request.model_copy(update={"sample_rate": 100_000.0})
    with pytest.raises(InputError) as caught:
        _check_grid(rig, {}, stalled, fast, 1_000_000, None)
    said = float(caught.value.message.split("about ")[1].split(" rows")[0].replace(",", ""))
    expected = 1e5 * (guard + min(steady.return_["duration"], 600.0))
    assert said == pytest.approx(expected, rel=1e-6) and said < 600 * 1e5
