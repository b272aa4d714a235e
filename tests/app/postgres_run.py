"""The service's tests on PostgreSQL: ``make test-postgres``.

The service keeps its store in SQLite by default and in PostgreSQL by URL; ``make test``
runs its HTTP and command-line tests on SQLite files, and only a few tests (migrations,
copy, locks) on PostgreSQL.  This runs the tests of ``tests/app`` (every route, the
console, jobs, the history, the command line) with each live server's store, and each
CLI test's (the ``runner`` fixture: :func:`tests.app.conftest.cli_store`), a new database
on one throw-away PostgreSQL server (:data:`tests.app.live.STORE_SERVER_ENV`); the tests
about the SQLite file itself keep theirs (``sqlite_settings``, ``sqlite_runner``).  The
server is :func:`tests.app.postgres.postgres_url`'s: started in a temporary folder where
PostgreSQL's programs are installed, or the one ``HYDRODIAG_TEST_POSTGRES_URL`` names
(whose user may create databases: each store is one, left behind).  Where neither can be
had it says why and exits 0, as the PostgreSQL tests of ``make test`` skip.

``python -m tests.app.postgres_run [pytest arguments]`` (default: ``tests/app -q -n 2``).
"""

from __future__ import annotations

import os
import subprocess
import sys

from sqlalchemy.engine import make_url

from tests.app import postgres
from tests.app.live import STORE_SERVER_ENV


def server_of(url: str) -> str:
    """The server part of a database URL (``postgresql+psycopg://user@host:port``)."""
    parsed = make_url(url)
    return parsed.set(database="").render_as_string(hide_password=False).rstrip("/")


def main(argv: list[str]) -> int:
    """Run pytest with ``argv`` (or the default) against a PostgreSQL server."""
    reason = postgres.unavailable_reason()
    if reason is not None:
        print(f"make test-postgres: skipped, {reason}")
        return 0
    args = argv or ["tests/app", "-q", "-n", "2"]
    with postgres.postgres_url() as url:
        env = os.environ | {STORE_SERVER_ENV: server_of(url)}
        shown = make_url(url).set(database="").render_as_string()  # password hidden
        print(f"make test-postgres: stores on {shown.rstrip('/')}", flush=True)
        return subprocess.run([sys.executable, "-m", "pytest", *args], env=env,
                              check=False).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
