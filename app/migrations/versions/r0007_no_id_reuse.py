"""SQLite never reuses a deleted row's id: every table with an integer key gets ``AUTOINCREMENT``.

Without it SQLite gives the highest freed id to the next row: after ``DELETE /series/8`` the
next import was series 8 again, and a diagnosis read from the deleted series (its record
keeps ``series_id``) linked to an unrelated cycle; a deleted rig's id went to the next rig
a stored job names.  SQLite cannot add ``AUTOINCREMENT`` to a table, so each is rebuilt
(batch mode: its rows, ids, constraints and indexes copied; foreign keys are off while
migrations run, :mod:`app.migrations.env`).  Ids freed before this revision may still be
given once more; none after it.  PostgreSQL's sequences never reuse ids: nothing to do.

Revision ID: 0007
Revises: 0006
Create Date: 2026-11-28
"""

from __future__ import annotations

from alembic import op

revision: str = "0007"
down_revision: str | None = "0006"
branch_labels: str | None = None
depends_on: str | None = None

#: every table with an integer key
TABLES = ("rigs", "rig_versions", "throttle_calibrations", "calibration_points", "pump_sets",
          "measurements", "measured_series", "diagnoses", "diagnosis_estimates", "api_keys")


def _rebuild(autoincrement: bool) -> None:
    if op.get_bind().dialect.name != "sqlite":
        return
    for table in TABLES:
        with op.batch_alter_table(table, recreate="always",
                                  table_kwargs={"sqlite_autoincrement": autoincrement}):
            pass


def upgrade() -> None:
    """Rebuild each table with ``AUTOINCREMENT`` (SQLite)."""
    _rebuild(True)


def downgrade() -> None:
    """Rebuild each table without it (SQLite)."""
    _rebuild(False)
