"""Engine and session factory of the store.

SQLite files get write-ahead logging, foreign-key enforcement and a busy timeout on every
connection; PostgreSQL needs nothing special.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event, text
from sqlalchemy.engine import URL
from sqlalchemy.orm import Session, sessionmaker

__all__ = ["SessionFactory", "make_engine", "make_session_factory", "ping"]

SessionFactory = sessionmaker[Session]

#: How long an SQLite connection waits for another writer before failing [ms].
SQLITE_BUSY_TIMEOUT_MS = 10_000
#: Connections kept open to an SQLite file, and opened beyond them when all are in use:
#: as many as the threads that may read the store at once (the thread pool's 40 and the
#: job threads), so that no request waits for a connection (SQLite's are cheap).
SQLITE_POOL_SIZE, SQLITE_POOL_OVERFLOW = 16, 48


def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
    cursor = dbapi_connection.cursor()
    try:
        cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.execute("PRAGMA synchronous=NORMAL")
        cursor.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_TIMEOUT_MS}")
    finally:
        cursor.close()


def make_engine(url: URL) -> Engine:
    """Create the engine for ``url``.

    Parameters
    ----------
    url
        Database URL; for SQLite the file's folder is created when missing.

    Returns
    -------
    Engine
        An engine whose connections are configured for the service (see module docstring).
    """
    if url.get_backend_name() == "sqlite":
        if url.database:
            Path(url.database).parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(url, connect_args={"check_same_thread": False},
                               pool_size=SQLITE_POOL_SIZE, max_overflow=SQLITE_POOL_OVERFLOW)
        event.listen(engine, "connect", _sqlite_pragmas)
        return engine
    return create_engine(url, pool_pre_ping=True)


def make_session_factory(engine: Engine) -> SessionFactory:
    """Return a session factory bound to ``engine`` (objects stay usable after commit)."""
    return sessionmaker(engine, expire_on_commit=False)


def ping(engine: Engine) -> None:
    """Run a trivial query; raises the driver's error when the database is unreachable."""
    with engine.connect() as connection:
        connection.execute(text("SELECT 1"))
