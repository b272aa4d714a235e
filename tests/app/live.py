"""A real hydrodiag server on a free local port, for tests that go through HTTP."""

from __future__ import annotations

import os
import socket
import threading
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import uvicorn
from sqlalchemy import Engine, func, select
from sqlalchemy.orm import Session

from app.db.base import Base
from app.db.engine import SessionFactory, make_engine, make_session_factory
from app.main import create_app
from app.services.bootstrap import ensure_first_key
from app.services.clearance import ClearanceEstimator
from app.services.keys import create_api_key
from app.settings import Settings

#: start-up warms the stored rigs' evaluators; on a loaded CI machine (a study beside the
#: tests) that took more than a minute, so the bound is generous: it only ends a hung start
STARTUP_TIMEOUT_S = 180.0
#: the tests' own wall-clock budget of one simulation [s]: the service's default (10 s) is a
#: limit for users, and a test that is not about it must not fail because the machine is busy
TEST_SIM_WALL_CLOCK_S = 120.0


@dataclass
class LiveServer:
    """A running server, clients for it and a separate engine on the same store.

    ``client`` sends the server's API key on every request (every operation but
    ``/health``, ``/ready`` and ``/metrics`` needs one by default); ``anon`` sends none.
    """

    base_url: str
    settings: Settings
    app: Any
    key: str
    client: httpx.Client
    anon: httpx.Client
    engine: Engine
    sessions: SessionFactory

    @property
    def auth(self) -> dict[str, str]:
        """Headers that carry the server's API key."""
        return {"X-API-Key": self.key}

    def session(self) -> Session:
        """A session of the store, independent of the server's."""
        return self.sessions()

    def row_counts(self) -> dict[str, int]:
        """Number of rows in every table of the store."""
        with self.sessions() as session:
            return {
                table.name: int(session.scalar(select(func.count()).select_from(table)) or 0)
                for table in Base.metadata.sorted_tables
            }


#: a PostgreSQL server (``postgresql+psycopg://user@host:port``, a throw-away one: its
#: databases are left behind) on which every :func:`store_settings` store is a database
#: of its own instead of an SQLite file: ``make test-postgres`` runs the service's tests so
STORE_SERVER_ENV = "HYDRODIAG_TEST_STORE_SERVER"


def store_settings(data_dir: Path, **overrides: Any) -> Settings:
    """Settings for a store in ``data_dir`` — an SQLite file, or a new database on the
    server :data:`STORE_SERVER_ENV` names — with the tests' wall-clock budget of a
    simulation (:data:`TEST_SIM_WALL_CLOCK_S`) unless ``overrides`` name one."""
    url = None if "database_url" in overrides else store_database_url()
    store = {} if url is None else {"database_url": url}
    return Settings(data_dir=data_dir,
                    **({"sim_wall_clock": TEST_SIM_WALL_CLOCK_S} | store | overrides))


def sqlite_settings(data_dir: Path, **overrides: Any) -> Settings:
    """:func:`store_settings` on an SQLite file in ``data_dir`` whatever
    :data:`STORE_SERVER_ENV` says: for tests of the SQLite file itself (its copy, its
    repair at start, its permissions)."""
    return store_settings(data_dir, **({"database_url": None} | overrides))


def store_database_url() -> str | None:
    """The URL of a new database on the server :data:`STORE_SERVER_ENV` names, or ``None``
    (the store is the SQLite file of its data folder) when it names none: the one choice
    of :func:`store_settings` and of the CLI tests' ``runner`` (``tests/app/conftest.py``)."""
    server = os.environ.get(STORE_SERVER_ENV)
    return new_database(server) if server else None


def new_database(server: str) -> str:
    """The URL of a new, empty database on the PostgreSQL ``server``."""
    from sqlalchemy import create_engine, text

    name = f"hd_{uuid.uuid4().hex[:16]}"
    engine = create_engine(f"{server.rstrip('/')}/postgres", isolation_level="AUTOCOMMIT")
    try:
        with engine.connect() as connection:
            connection.execute(text(f'CREATE DATABASE "{name}"'))
    finally:
        engine.dispose()
    return f"{server.rstrip('/')}/{name}"


@contextmanager
def live_server(
    settings: Settings, *, estimator: ClearanceEstimator | None = None
) -> Iterator[LiveServer]:
    """Run the application with uvicorn in a thread on a free port until the block ends."""
    app = create_app(settings, clearance_estimator=estimator)
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="on"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while not server.started:
        if not thread.is_alive():
            raise RuntimeError("the server thread stopped during start-up")
        if time.monotonic() > deadline:
            raise RuntimeError("the server did not start in time")
        time.sleep(0.02)
    engine = make_engine(settings.url)
    sessions = make_session_factory(engine)
    with sessions() as session:  # as `serve` does; a restarted store gets one more key
        key = ensure_first_key(session) or create_api_key(session, f"test-{uuid.uuid4()}")[1]
    base_url = f"http://127.0.0.1:{port}"
    try:
        with httpx.Client(base_url=base_url, timeout=30.0, headers={"X-API-Key": key}) as client, \
                httpx.Client(base_url=base_url, timeout=30.0) as anon:
            # as a load balancer would: no request before the service says it is ready
            while anon.get("/ready").status_code != 200:
                if time.monotonic() > deadline:
                    raise RuntimeError("the server did not become ready in time")
                time.sleep(0.05)
            yield LiveServer(base_url, settings, app, key, client, anon, engine, sessions)
    finally:
        server.should_exit = True
        thread.join(timeout=30)
        engine.dispose()
        sock.close()
