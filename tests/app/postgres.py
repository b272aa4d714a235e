"""A PostgreSQL server for the tests, when one can be had.

``HYDRODIAG_TEST_POSTGRES_URL`` (a SQLAlchemy URL of a database the tests may fill and
empty) wins; otherwise, when PostgreSQL's server programs and the psycopg driver are
installed, a throw-away cluster is started in a temporary folder (as the ``postgres`` user
when the tests run as root, since PostgreSQL refuses to run as root).  Without either the
PostgreSQL tests are skipped, with the reason.
"""

from __future__ import annotations

import glob
import importlib.util
import os
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

ENV_URL = "HYDRODIAG_TEST_POSTGRES_URL"


def _bin(name: str) -> str | None:
    found = shutil.which(name)
    if found:
        return found
    candidates = sorted(glob.glob(f"/usr/lib/postgresql/*/bin/{name}"))
    return candidates[-1] if candidates else None


def unavailable_reason() -> str | None:
    """Why no PostgreSQL server can be had here, or ``None`` if one can."""
    if os.environ.get(ENV_URL):
        return None
    if importlib.util.find_spec("psycopg") is None:
        return f"no psycopg driver installed and {ENV_URL} not set"
    if _bin("initdb") is None or _bin("pg_ctl") is None:
        return f"no PostgreSQL server programs (initdb, pg_ctl) and {ENV_URL} not set"
    if os.geteuid() == 0 and (shutil.which("runuser") is None or _uid("postgres") is None):
        return "running as root without a 'postgres' user to start the server as"
    return None


def _uid(user: str) -> int | None:
    import pwd

    try:
        return pwd.getpwnam(user).pw_uid
    except KeyError:
        return None


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@contextmanager
def postgres_url() -> Iterator[str]:
    """Yield the URL of an empty PostgreSQL database (see the module docstring)."""
    given = os.environ.get(ENV_URL)
    if given:
        yield given
        return
    initdb, pg_ctl = _bin("initdb"), _bin("pg_ctl")
    assert initdb and pg_ctl
    # not under pytest's tmp_path: its parents are private to the user running the tests
    folder = Path(tempfile.mkdtemp(prefix="hydrodiag-pg-"))
    data = folder / "pgdata"
    prefix: list[str] = []
    if os.geteuid() == 0:
        import pwd

        user = pwd.getpwnam("postgres")
        os.chown(folder, user.pw_uid, user.pw_gid)
        prefix = ["runuser", "-u", "postgres", "--"]
    port = _free_port()
    try:
        subprocess.run([*prefix, initdb, "-D", str(data), "-U", "hydrodiag", "--auth=trust",
                        "-E", "UTF8"], check=True, capture_output=True)
        # a throw-away cluster: no fsync; room for every live server's pool of a parallel
        # run (make test-postgres)
        options = (f"-c listen_addresses=127.0.0.1 -c port={port} "
                   f"-c unix_socket_directories={data} -c fsync=off -c max_connections=300")
        subprocess.run([*prefix, pg_ctl, "-D", str(data), "-o", options, "-w", "-t", "60",
                        "-l", str(folder / "server.log"), "start"], check=True,
                       capture_output=True)
        try:
            yield f"postgresql+psycopg://hydrodiag@127.0.0.1:{port}/postgres"
        finally:
            subprocess.run([*prefix, pg_ctl, "-D", str(data), "-m", "immediate", "stop"],
                           check=False, capture_output=True)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@contextmanager
def emptied_postgres_url() -> Iterator[str]:
    """:func:`postgres_url`, its schema taken back to empty afterwards (a database given by
    ``HYDRODIAG_TEST_POSTGRES_URL`` outlives the test)."""
    from sqlalchemy.engine import make_url

    from app.db import migrate
    from app.db.engine import make_engine

    with postgres_url() as url:
        try:
            yield url
        finally:
            engine = make_engine(make_url(url))
            try:
                migrate.downgrade(engine, "base")
            finally:
                engine.dispose()
