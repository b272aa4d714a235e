"""Fixtures: live servers on SQLite files in temporary folders."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from sim.rigs import reference_rig_document
from tests.app.live import LiveServer, live_server, store_settings


def first_api_key(data_dir: Path, output: str) -> str:
    """The first API key a piped ``serve`` left in ``data_dir``: its output names the file,
    never the key, and the file is readable by its owner only (a log keeps what it is
    given: an operator found the admin key in the journal)."""
    path = (data_dir / "first-api-key").resolve()
    assert f"API key: written to {path} " in output, output
    assert path.stat().st_mode & 0o777 == 0o600
    key = path.read_text().strip()
    assert key.startswith("hd_") and key not in output
    return key


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    """A server with open reads, shared by the tests of one module."""
    with live_server(store_settings(tmp_path_factory.mktemp("store"))) as live:
        yield live


@pytest.fixture
def runner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> CliRunner:
    """A CLI runner on an SQLite store in ``tmp_path`` (no database URL, no Dask scheduler)."""
    monkeypatch.setenv("HYDRODIAG_DATA_DIR", str(tmp_path))
    monkeypatch.delenv("HYDRODIAG_DATABASE_URL", raising=False)
    monkeypatch.delenv("HYDRODIAG_DASK_SCHEDULER", raising=False)
    return CliRunner()


@pytest.fixture
def rig_document() -> Any:
    """A fresh copy of the reference rig document, to rename and modify."""
    return reference_rig_document()


def new_rig(server: LiveServer, name: str, **changes: Any) -> dict[str, Any]:
    """Create a rig named ``name`` from the reference document; return its JSON."""
    document = reference_rig_document() | {"name": name} | changes
    response = server.client.post("/rigs", json={"document": document}, headers=server.auth)
    assert response.status_code == 201, response.text
    return dict(response.json())


def simulated_record(server: LiveServer, overrides: dict[str, float] | None = None, *,
                     rig_id: int = 1, load: float = 2100.0,
                     measured_at: str | None = None) -> dict[str, Any]:
    """A measurement record of what the rig would read with ``overrides`` (steady path).

    The readings carry their default instrument classes; the rig is simulated through
    ``POST /simulate``.
    """
    response = server.client.post("/simulate", json={
        "rig_id": rig_id, "overrides": overrides or {}, "method": "steady",
        "condition": {"load": load, "oil_temperature": 40.0}})
    assert response.status_code == 200, response.text
    s = response.json()["summary"]
    record: dict[str, Any] = {
        "rig_id": rig_id,
        "condition": {"oil_temperature": 40.0, "load_force": load},
        "pump_pressure": s["working.P_pump [Pa]"], "p1": s["working.P1 [Pa]"],
        "p2": s["working.P2 [Pa]"], "flow_B": s["working.Q_meter_B [m^3/s]"],
        "flow_C": s["working.Q_meter_C [m^3/s]"], "speed_work": s["working.speed [m/s]"],
        "speed_return": s["return.speed [m/s]"],
    }
    if measured_at is not None:
        record["measured_at"] = measured_at
    return record


def store_count(model: Any) -> int:
    """Rows of ``model`` in the store the CLI uses (``HYDRODIAG_DATA_DIR`` of :func:`runner`)."""
    from sqlalchemy import func, select

    from app.db.engine import make_engine, make_session_factory
    from app.settings import Settings

    engine = make_engine(Settings().url)
    try:
        with make_session_factory(engine)() as session:
            return int(session.scalar(select(func.count()).select_from(model)) or 0)
    finally:
        engine.dispose()
