"""Alembic, configured in code so migrations run from the installed package.

The scripts live in ``app/migrations`` (shipped as package data); nothing here depends on
the current directory or on an ``alembic.ini`` being found.
"""

from __future__ import annotations

import functools
from pathlib import Path

from alembic import command
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import Engine

__all__ = ["MIGRATIONS_DIR", "alembic_config", "current_revision", "downgrade", "head_revision",
           "revision_list", "upgrade"]

#: Folder of the migration scripts inside the installed ``app`` package.
MIGRATIONS_DIR = Path(__file__).resolve().parent.parent / "migrations"


def alembic_config(engine: Engine | None = None) -> Config:
    """Build an Alembic configuration for the package's migrations.

    Parameters
    ----------
    engine
        Engine to migrate; ``env.py`` uses a connection from it.  Without one, ``env.py``
        falls back to the URL of :class:`app.settings.Settings`.

    Returns
    -------
    Config
        A configuration with ``script_location`` set to :data:`MIGRATIONS_DIR`.
    """
    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS_DIR))
    if engine is not None:
        config.attributes["engine"] = engine
    return config


def upgrade(engine: Engine, revision: str = "head") -> None:
    """Migrate the database of ``engine`` up to ``revision`` (default: the newest)."""
    command.upgrade(alembic_config(engine), revision)


def downgrade(engine: Engine, revision: str) -> None:
    """Migrate the database of ``engine`` down to ``revision`` (``"base"``: empty)."""
    command.downgrade(alembic_config(engine), revision)


def current_revision(engine: Engine) -> str | None:
    """Return the revision the database is at, or ``None`` for an unmigrated database.

    Read without the engine's statement cache: Alembic builds a new ``alembic_version``
    table at each call, so each read compiled into a new cache entry — every ``/ready``
    probe (a soak run: one in eight requests) added one, up to the cache's 500, pushing the
    service's own compiled statements out.
    """
    with engine.connect() as connection:
        uncached = connection.execution_options(compiled_cache=None)
        return MigrationContext.configure(uncached).get_current_revision()


@functools.cache
def known_revisions() -> frozenset[str]:
    """Every revision shipped with the package."""
    return frozenset(s.revision for s in ScriptDirectory.from_config(alembic_config())
                     .walk_revisions())


def revision_list() -> list[tuple[str, str, str]]:
    """Every revision shipped, oldest first: (revision, its ``Create Date``, the first line
    of its docstring)."""
    out: list[tuple[str, str, str]] = []
    for script in ScriptDirectory.from_config(alembic_config()).walk_revisions():
        doc = script.module.__doc__ or ""
        date = next((line.split(":", 1)[1].strip() for line in doc.splitlines()
                     if line.startswith("Create Date:")), "")
        summary = " ".join(script.doc.split()) if script.doc else ""
        out.append((script.revision, date, summary))
    return out[::-1]


@functools.cache
def head_revision() -> str:
    """Return the newest revision shipped with the package (read once per process)."""
    head = ScriptDirectory.from_config(alembic_config()).get_current_head()
    if head is None:  # pragma: no cover - the package always ships a revision
        raise RuntimeError(f"no migration scripts in {MIGRATIONS_DIR}")
    return head
