"""Alembic environment of hydrodiag.

Runs with an engine handed over by :func:`app.db.migrate.alembic_config` (the service and
the CLI), or, from the ``alembic`` command line, with the URL of the service settings.
SQLite gets batch mode so that later migrations can alter tables portably.
"""

from __future__ import annotations

from alembic import context
from sqlalchemy import Engine

from app.db.engine import lift_timeouts, make_engine
from app.db.models import Base

config = context.config
target_metadata = Base.metadata


def _engine() -> Engine:
    engine = config.attributes.get("engine")
    if isinstance(engine, Engine):
        return engine
    from app.settings import Settings

    return make_engine(Settings().url)


def run_migrations_offline() -> None:
    """Emit the migration SQL for the settings' database without connecting."""
    from app.settings import Settings

    context.configure(
        url=Settings().url,
        target_metadata=target_metadata,
        literal_binds=True,
        dialect_opts={"paramstyle": "named"},
    )
    with context.begin_transaction():
        context.run_migrations()


def run_migrations_online() -> None:
    """Migrate the database over a live connection.

    On SQLite, foreign keys are off while the migrations run: batch mode rebuilds a table
    by copying it and dropping the old one, and with foreign keys on, dropping a table
    deletes its rows first, which would cascade into the tables that refer to it.  Before
    the migrations commit, ``PRAGMA foreign_key_check`` must find no broken reference.
    """
    engine = _engine()
    with engine.connect() as connection:
        sqlite = connection.dialect.name == "sqlite"
        if sqlite:  # outside a transaction: SQLite ignores the pragma inside one
            connection.exec_driver_sql("PRAGMA foreign_keys=OFF")
            connection.commit()
        try:
            context.configure(
                connection=connection,
                target_metadata=target_metadata,
                render_as_batch=sqlite,
                compare_type=True,
            )
            with context.begin_transaction():
                lift_timeouts(connection)   # the service's engine cuts long statements
                context.run_migrations()
                if sqlite and (broken := connection.exec_driver_sql(
                        "PRAGMA foreign_key_check").fetchall()):
                    raise RuntimeError(f"the migration broke references: {broken[:5]}")
        finally:
            if sqlite:
                connection.exec_driver_sql("PRAGMA foreign_keys=ON")
                connection.commit()


if context.is_offline_mode():
    run_migrations_offline()
else:
    run_migrations_online()
