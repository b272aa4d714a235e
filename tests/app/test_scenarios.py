"""POST /scenarios: sweeps as jobs on the local process pool (and on Dask when installed)."""

from __future__ import annotations

import importlib.util
import re
import time
from collections.abc import Iterator
from typing import Any

import pytest

from sim.rigs import Condition, reference_rig
from sim.scenarios import fault_overrides
from sim.steady import steady_cycle
from tests.app.live import LiveServer, live_server, store_settings

POLL_TIMEOUT_S = 120.0

SWEEP: dict[str, Any] = {
    "rig_id": 1,
    "faults": ["healthy", "worn_spool"],
    "parameters": [{"name": "cylinder.cc", "low": 83e-6, "high": 130e-6, "levels": 3}],
    "conditions": [{"name": "load", "low": 2100.0, "high": 6300.0, "levels": 2}],
}


def _follow(server: LiveServer, job_id: str) -> tuple[dict[str, Any], list[float]]:
    """Poll the job until it ends; return it and the progress values seen on the way."""
    seen: list[float] = []
    deadline = time.monotonic() + POLL_TIMEOUT_S
    while True:
        body = server.client.get(f"/jobs/{job_id}").json()
        seen.append(body["progress"])
        if body["status"] in ("succeeded", "failed"):
            return dict(body), seen
        if time.monotonic() > deadline:
            raise AssertionError(f"sweep {job_id} stuck at {body['progress']}")
        time.sleep(0.05)


def _column(result: dict[str, Any], name: str) -> list[Any]:
    index = result["columns"].index(name)
    return [row[index] for row in result["rows"]]


def _check_grid(result: dict[str, Any]) -> None:
    assert result["n_points"] == 12 and result["n_failed"] == 0
    assert result["columns"][:3] == ["fault", "cylinder.cc", "condition.load"]
    assert sorted(set(_column(result, "fault"))) == ["healthy", "worn_spool"]
    assert sorted(set(_column(result, "cylinder.cc"))) == pytest.approx([83e-6, 106.5e-6,
                                                                          130e-6])
    leak = {(row[0], row[1], row[2]): row[result["columns"].index(
        "working.Q_valve_leak [m^3/s]")] for row in result["rows"]}
    rig = reference_rig()
    for (fault, cc, load), q in leak.items():
        # the sweep carries the steady solver's numbers through untouched
        alone = steady_cycle(rig, fault_overrides(rig, fault) | {"cylinder.cc": cc},
                             Condition(load=load))
        assert q == pytest.approx(alone.working["Q_valve_leak"], rel=1e-9)
        if fault == "worn_spool":
            # cv 60 µm against 34 µm at the same point: leakage ∝ cv³ (paper 002 eq. 23),
            # 0.995× of it as the spool's Δp falls ~0.5 % with the larger leak
            assert q / leak[("healthy", cc, load)] == pytest.approx((60 / 34) ** 3, rel=0.01)


def test_a_grid_sweep_runs_to_completion_with_progress(server: LiveServer) -> None:
    before = server.row_counts()
    response = server.client.post("/scenarios", json=SWEEP, headers=server.auth)
    assert response.status_code == 202, response.text
    accepted = response.json()
    assert accepted["n_points"] == 12 and accepted["executor"] == "processes"
    assert response.headers["location"] == f"/jobs/{accepted['job_id']}"
    job, seen = _follow(server, accepted["job_id"])
    assert job["status"] == "succeeded", job["error"]
    assert job["kind"] == "sweep" and job["progress"] == 1.0
    assert job["message"] == "point 12 of 12"
    assert seen == sorted(seen)  # progress never goes back
    _check_grid(job["result"])
    assert server.row_counts()["jobs"] == before["jobs"] + 1


def test_a_cancelled_sweep_stops_without_its_remaining_points(server: LiveServer) -> None:
    """POST /jobs/{id}/cancel on a running sweep: it stops at its next progress report
    (the chunks not started are cancelled on the pool) and keeps no result."""
    # the most transient points a request takes: ~4 s of work on two cores, so the cancel
    # (sent as soon as the first chunk is reported) arrives while most are still queued
    body = {"rig_id": 1, "faults": ["healthy"], "design": "lhs", "samples": 200, "seed": 3,
            "method": "transient",
            "conditions": [{"name": "oil_temperature", "low": 30.0, "high": 60.0}]}
    accepted = server.client.post("/scenarios", json=body, headers=server.auth).json()
    job_id = accepted["job_id"]
    deadline = time.monotonic() + POLL_TIMEOUT_S
    while server.client.get(f"/jobs/{job_id}").json()["progress"] == 0.0:
        assert time.monotonic() < deadline, "the sweep never reported"
        time.sleep(0.01)
    asked = server.client.post(f"/jobs/{job_id}/cancel", headers=server.auth)
    assert asked.status_code == 202, asked.text
    while (job := server.client.get(f"/jobs/{job_id}").json())["status"] == "running":
        assert time.monotonic() < deadline, "the cancel never reached the sweep"
        time.sleep(0.05)
    assert job["status"] == "cancelled", job
    assert job["result"] is None and job["error"]["type"] == "JobCancelledError"
    found = re.fullmatch(r"cancelled on request at point (\d+) of 200", job["message"])
    assert found is not None, job["message"]
    done = int(found.group(1))
    assert 0 < done < 200 and job["progress"] == pytest.approx(done / 200)


def test_a_latin_hypercube_of_transient_runs(server: LiveServer) -> None:
    body = {"rig_id": 1, "faults": ["healthy"], "design": "lhs", "samples": 3, "seed": 5,
            "method": "transient",
            "conditions": [{"name": "oil_temperature", "low": 30.0, "high": 60.0}]}
    accepted = server.client.post("/scenarios", json=body, headers=server.auth).json()
    job, _ = _follow(server, accepted["job_id"])
    assert job["status"] == "succeeded", job["error"]
    temperatures = sorted(_column(job["result"], "condition.oil_temperature"))
    # one sample in each third of the range
    assert [int((t - 30.0) // 10.0) for t in temperatures] == [0, 1, 2]


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"faults": ["worn_spool", "gone"]}, "faults"),
        ({"faults": []}, "faults"),
        ({"parameters": [{"name": "valve.cv", "low": 5e-5, "high": 4e-5}]}, "parameters[0]"),
        ({"parameters": [{"name": "valve.cv", "low": -1e-6, "high": 4e-5}]},
         "parameters[0].low"),
        ({"parameters": [{"name": "valve.nothing", "low": 1.0, "high": 2.0}]},
         "parameters[0].name"),
        # worn_spool sets valve.cv itself: its points would be 'healthy' ones, mislabelled
        ({"parameters": [{"name": "valve.cv", "low": 34e-6, "high": 80e-6}]}, "faults[1]"),
        ({"conditions": [{"name": "humidity", "low": 1.0, "high": 2.0}]}, "conditions"),
        ({"conditions": [{"name": "pump_speed", "low": -5.0, "high": 100.0}]},
         "conditions[0].low"),
        ({"design": "lhs", "samples": 3000, "method": "transient"}, "design"),
        ({"method": "euler"}, "method"),
    ],
)
def test_bad_sweeps_are_422_and_start_nothing(server: LiveServer, change: dict[str, Any],
                                              field: str) -> None:
    before = server.row_counts()
    response = server.client.post("/scenarios", json=SWEEP | change, headers=server.auth)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == field
    assert server.row_counts() == before


def test_a_sweep_needs_the_key_and_a_known_rig(server: LiveServer) -> None:
    before = server.row_counts()
    assert server.anon.post("/scenarios", json=SWEEP).status_code == 401
    unknown = server.client.post("/scenarios", json=SWEEP | {"rig_id": 777},
                                 headers=server.auth)
    assert unknown.status_code == 404 and unknown.json()["error"]["field"] == "rig_id"
    assert server.row_counts() == before


@pytest.fixture(scope="module")
def dask_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    if importlib.util.find_spec("distributed") is None:
        pytest.skip("dask.distributed is not installed (optional: pip install 'dask[distributed]')")
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=None) as cluster:
        settings = store_settings(tmp_path_factory.mktemp("dask"),
                                   dask_scheduler=cluster.scheduler_address)
        with live_server(settings) as live:
            yield live


def test_the_same_sweep_runs_on_a_dask_cluster(dask_server: LiveServer) -> None:
    response = dask_server.client.post("/scenarios", json=SWEEP, headers=dask_server.auth)
    assert response.status_code == 202, response.text
    assert response.json()["executor"] == "dask"
    job, _ = _follow(dask_server, response.json()["job_id"])
    assert job["status"] == "succeeded", job["error"]
    _check_grid(job["result"])
