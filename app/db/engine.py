"""Engine and session factory of the store.

SQLite files get write-ahead logging, foreign-key enforcement and a busy timeout on every
connection; PostgreSQL connections give up connecting after ``connect_timeout``, and the
service's own (``make_engine(..., lock_timeout_s=...)``) wait at most that long for a lock
and cut a statement at :data:`PG_STATEMENT_TIMEOUT_S`, so a request stalled by another
session's lock is a 503 (:func:`app.errors.database_unavailable`), not a thread held for as
long as the lock (an operator pass); the bootstrap and the migrations lift both
(:func:`lift_timeouts`).  JSON columns are written and read with
orjson (:func:`dumps_json`, :func:`loads_json`): a measured series of 10⁵ samples × 7
channels is 11 MB of JSON, which the standard library took 0.55 s to write (holding the
interpreter lock, so that ``/health`` waited) and orjson 0.03 s; the values are the same,
each float the shortest text that reads back to it (orjson spells ``1e-6`` where the
standard library writes ``1e-06``).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import orjson
from sqlalchemy import Connection, Engine, create_engine, event, text
from sqlalchemy.engine import URL
from sqlalchemy.orm import Session, sessionmaker

from sim.errors import InputError

__all__ = ["SessionFactory", "dumps_json", "lift_timeouts", "loads_json", "make_engine",
           "make_session_factory", "ping", "private_file", "sqlite_path"]

SessionFactory = sessionmaker[Session]

#: How long an SQLite connection waits for another writer before failing [ms].
SQLITE_BUSY_TIMEOUT_MS = 10_000
#: Connections kept open to an SQLite file, and opened beyond them when all are in use:
#: as many as the threads that may read the store at once (the thread pool's 40 and the
#: job threads), so that no request waits for a connection (SQLite's are cheap).
SQLITE_POOL_SIZE, SQLITE_POOL_OVERFLOW = 16, 48


_ORJSON = orjson.OPT_NON_STR_KEYS | orjson.OPT_SERIALIZE_NUMPY


#: how long a new PostgreSQL connection may take [s] (libpq ``connect_timeout``)
PG_CONNECT_TIMEOUT_S = 10
#: the longest statement of a served request on PostgreSQL [s] (``statement_timeout``;
#: the longest the service runs, a trend over 12,600 diagnoses, takes under a second)
PG_STATEMENT_TIMEOUT_S = 60.0


def dumps_json(value: Any) -> str:
    """A JSON column's text: orjson's, which holds the values the standard library's would
    (shortest round-trip floats; non-string keys as strings; numpy numbers as numbers), or
    the standard library's where orjson refuses a value (an integer beyond 64 bits).
    Non-finite floats are never stored (PostgreSQL's JSONB has none; the services map them
    to null first, :func:`app.services.diagnosis_estimates.json_ready`); orjson writes null for one."""
    try:
        return orjson.dumps(value, option=_ORJSON).decode("utf-8")
    except TypeError:
        return json.dumps(value)


def loads_json(text: str | bytes) -> Any:
    """A JSON column's value; the standard library reads what orjson refuses (a ``NaN``
    token an older store may hold)."""
    try:
        return orjson.loads(text)
    except orjson.JSONDecodeError:
        return json.loads(text)


def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
    cursor = dbapi_connection.cursor()
    try:
        cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.execute("PRAGMA synchronous=NORMAL")
        cursor.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_TIMEOUT_MS}")
    finally:
        cursor.close()


def private_file(path: Path, mode: int = 0o600) -> None:
    """Create ``path`` empty with ``mode`` where it does not exist (SQLite takes an empty
    file as a new database, and its -wal and -shm files take the database file's mode): a
    new store, and a backup, were world-readable (key hashes and every record; an
    operator's pass), where the console's secret beside them is 0600.  A file that exists
    keeps the mode its operator gave it; a folder it cannot write is left to the caller's
    error."""
    try:
        os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, mode))
    except FileExistsError:
        pass
    except OSError:
        return


def sqlite_path(url: URL) -> Path | None:
    """The file of an SQLite store's ``url``: None for an in-memory store or another
    backend, the path of a URI filename (``sqlite:///file:/srv/h.db?mode=ro&uri=true``).
    Every question of the store's file asks here: taken as a plain path, ``file:/srv/h.db``
    made a folder ``file:`` in the current one (a verification pass found one in the
    repository after the tests)."""
    database = url.database
    if url.get_backend_name() != "sqlite" or not database or database == ":memory:" \
            or url.query.get("mode") == "memory" or database.startswith("file::memory:"):
        return None
    if database.startswith("file:"):
        from urllib.parse import unquote, urlsplit

        return Path(unquote(urlsplit(database).path))
    return Path(database)


def make_engine(url: URL, *, lock_timeout_s: float | None = None) -> Engine:
    """Create the engine for ``url``.

    Parameters
    ----------
    url
        Database URL; for SQLite the file's folder is created when missing.
    lock_timeout_s
        On PostgreSQL, how long a statement waits for a lock [s] (``lock_timeout``), with
        statements cut at the larger of :data:`PG_STATEMENT_TIMEOUT_S` and it
        (``statement_timeout``): the service's requests; None (the CLI, copies,
        migrations run by hand): no limit.  An ``options`` parameter in the URL wins.

    Returns
    -------
    Engine
        An engine whose connections are configured for the service (see module docstring).
    """
    if url.get_backend_name() == "sqlite":
        if (path := sqlite_path(url)) is not None:
            folder = path.parent
            try:
                folder.mkdir(parents=True, exist_ok=True)
            except OSError as exc:  # a 101-line traceback (an operator's pass)
                raise InputError(f"cannot make the data folder {folder} ({exc.strerror}): "
                                 "set HYDRODIAG_DATA_DIR to a folder this user can write",
                                 field="HYDRODIAG_DATA_DIR") from None
            private_file(path)
        engine = create_engine(url, connect_args={"check_same_thread": False},
                               pool_size=SQLITE_POOL_SIZE, max_overflow=SQLITE_POOL_OVERFLOW,
                               json_serializer=dumps_json, json_deserializer=loads_json)
        event.listen(engine, "connect", _sqlite_pragmas)
        return engine
    # a server that accepts but does not answer (frozen, partitioned) held a new
    # connection for minutes (an operator pass); libpq's own setting in the URL wins
    connect: dict[str, Any] = ({} if "connect_timeout" in url.query
                               else {"connect_timeout": PG_CONNECT_TIMEOUT_S})
    if lock_timeout_s is not None and "options" not in url.query:
        statement_s = max(PG_STATEMENT_TIMEOUT_S, lock_timeout_s)
        connect["options"] = (f"-c lock_timeout={round(lock_timeout_s * 1000)} "
                              f"-c statement_timeout={round(statement_s * 1000)}")
    return create_engine(url, pool_pre_ping=True, json_serializer=dumps_json,
                         json_deserializer=loads_json, connect_args=connect)


def make_session_factory(engine: Engine) -> SessionFactory:
    """Return a session factory bound to ``engine`` (objects stay usable after commit)."""
    return sessionmaker(engine, expire_on_commit=False)


def ping(engine: Engine) -> None:
    """Run a trivial query; raises the driver's error when the database is unreachable."""
    with engine.connect() as connection:
        connection.execute(text("SELECT 1"))



def lift_timeouts(connection: Connection) -> None:
    """Lift the service's lock and statement timeouts on a PostgreSQL ``connection`` for
    its current transaction (``SET LOCAL``: the bootstrap's advisory lock waits for another
    replica's migration, a migration may run for minutes); nothing on SQLite."""
    if connection.dialect.name == "postgresql":
        connection.exec_driver_sql("SET LOCAL lock_timeout = 0")
        connection.exec_driver_sql("SET LOCAL statement_timeout = 0")
