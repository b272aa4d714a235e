"""Fixtures: live servers and CLI runners on new stores (SQLite files in temporary folders,
or PostgreSQL databases under ``make test-postgres``)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from sim.rigs import reference_rig_document
from tests.app.live import LiveServer, live_server, store_database_url, store_settings


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


def cli_store(monkeypatch: pytest.MonkeyPatch, data_dir: Path, *, sqlite: bool = False) -> None:
    """Point the CLI of this test at a new store with its data folder ``data_dir`` and no
    Dask scheduler: the SQLite file of ``data_dir``, or, when
    :data:`~tests.app.live.STORE_SERVER_ENV` names a PostgreSQL server (``make
    test-postgres``), a new database of its own there (:func:`~tests.app.live.store_database_url`,
    as :func:`~tests.app.live.store_settings` chooses a live server's store).  ``sqlite``
    keeps the SQLite file whatever that variable says, for tests of the file itself."""
    monkeypatch.setenv("HYDRODIAG_DATA_DIR", str(data_dir))
    url = None if sqlite else store_database_url()
    if url is None:
        monkeypatch.delenv("HYDRODIAG_DATABASE_URL", raising=False)
    else:
        monkeypatch.setenv("HYDRODIAG_DATABASE_URL", url)
    monkeypatch.delenv("HYDRODIAG_DASK_SCHEDULER", raising=False)


@pytest.fixture
def runner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> CliRunner:
    """A CLI runner on a new store in ``tmp_path``: its SQLite file, or a new PostgreSQL
    database under ``make test-postgres`` (:func:`cli_store`)."""
    cli_store(monkeypatch, tmp_path)
    return CliRunner()


@pytest.fixture
def sqlite_runner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> CliRunner:
    """:func:`runner` on the SQLite file of ``tmp_path`` whatever the test run's store
    server: for tests of the file itself (its path, its repair, its permissions, a copy
    from it)."""
    cli_store(monkeypatch, tmp_path, sqlite=True)
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
    """Rows of ``model`` in the store the CLI uses (that of :func:`runner`)."""
    from sqlalchemy import func, select

    from app.db.engine import make_engine, make_session_factory
    from app.settings import Settings

    engine = make_engine(Settings().url)
    try:
        with make_session_factory(engine)() as session:
            return int(session.scalar(select(func.count()).select_from(model)) or 0)
    finally:
        engine.dispose()
