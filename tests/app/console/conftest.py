"""Fixtures of the console tests: a live service whose history holds a wearing valve."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from diagnostics.pump import (
    InstrumentNoise,
    default_levels,
    iso4409_grid,
    run_virtual_bench,
    write_bench_csv,
)
from sim.components.gear_pump_map import stand_in_pump
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer, live_server, store_settings

#: The valve's clearance on successive days of the seeded history [m] (nominal 34 µm).
WEAR_SERIES_M = (34e-6, 38e-6, 42e-6, 46e-6)


def seed_history(server: LiveServer) -> list[dict[str, Any]]:
    """Diagnose, through the API, the readings of a valve wearing over four days."""
    stored = []
    for day, cv in enumerate(WEAR_SERIES_M):
        record = simulated_record(server, {"valve.cv": cv},
                                  measured_at=f"2026-03-0{day + 1}T08:00:00Z")
        response = server.client.post("/diagnose", json={"record": record},
                                      headers=server.auth)
        assert response.status_code == 200, response.text
        stored.append(response.json()["diagnoses"][0])
    return stored


def seed_pump_set(server: LiveServer, folder: Path) -> dict[str, Any]:
    """Parameterise a pump from a virtual ISO 4409 bench run (SIMULATED data) via the API."""
    dp, w = iso4409_grid(*default_levels())
    data = run_virtual_bench(stand_in_pump(), dp, w, (22.0, 60.0), noise=InstrumentNoise.none())
    write_bench_csv(data, folder / "bench.csv")
    response = server.client.post(
        "/pump-sets/bench", data={"name": "bench-gear", "pump": "external gear pump"},
        files={"file": ("bench.csv", (folder / "bench.csv").read_bytes(), "text/csv")},
        headers=server.auth)
    assert response.status_code == 201, response.text
    return dict(response.json())


def seed_series(server: LiveServer) -> list[int]:
    """Store, through the API, /simulate exports of a worn spool at two loads put in one
    table with a record column, as measured series of rig 1 (with their phase labels and
    the condition each export states in its columns); return their ids."""
    frames = []
    for load in (2100.0, 4200.0):
        response = server.client.post("/simulate", json={
            "rig_id": 1, "fault": "worn_spool", "condition": {"load": load},
            "sample_rate": 500, "timeseries": "csv"})
        assert response.status_code == 200, response.text
        lines = [ln for ln in response.text.splitlines() if not ln.startswith("#")]
        head, *rows = lines  # the export states its load and temperature as columns
        assert "load [N]" in head.split(",") and "oil_temperature [degC]" in head.split(",")
        frames += [f"load-{load:.0f},{row}" for row in rows]
    content = "\n".join([f"record,{head}", *frames]) + "\n"
    response = server.client.post("/rigs/1/series", data={"name": "worn-spool"},
                                  files={"file": ("cycles.csv", content.encode(), "text/csv")},
                                  headers=server.auth)
    assert response.status_code == 201, response.text
    return [int(item["id"]) for item in response.json()["items"]]


def login(server: LiveServer, client: httpx.Client | None = None) -> httpx.Client:
    """A client of ``server`` logged in to the console through its form."""
    client = client or httpx.Client(base_url=server.base_url, timeout=60.0)
    response = client.post("/console/login", data={"api_key": server.key,
                                                    "next": "/console/rigs"})
    assert response.status_code == 303, response.text
    return client


@pytest.fixture(scope="module")
def console_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    """A live service on a fresh store with :data:`WEAR_SERIES_M` diagnosed."""
    with live_server(store_settings(tmp_path_factory.mktemp("console-store"))) as live:
        live.seeded = seed_history(live)  # type: ignore[attr-defined]
        seed_pump_set(live, tmp_path_factory.mktemp("bench"))
        live.series = seed_series(live)  # type: ignore[attr-defined]
        yield live


@pytest.fixture(scope="module")
def browser_client(console_server: LiveServer) -> Iterator[httpx.Client]:
    """An HTTP client logged in to the console (cookie kept)."""
    with httpx.Client(base_url=console_server.base_url, timeout=60.0) as client:
        yield login(console_server, client)
