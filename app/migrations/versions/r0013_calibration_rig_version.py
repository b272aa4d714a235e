"""Each throttle table keeps the rig version whose document computed its clearances:
``throttle_calibrations.rig_version`` (null: none computed).

A technician stored a new rig version with a 15 % shorter seal length; the table's computed
clearances kept the old document's values (5 % high) and nothing said so, and an empty
``PATCH`` changed nothing.  The column lets the service say a table's computed clearances
are stale (``stale`` in the answer) and compute them again with the latest version on the
next update.  Tables stored before: the version is set only where the rig has one version
(the only document that can have computed them); elsewhere it stays null, which the
service reads as "not known: stale when any clearance was computed".

Revision ID: 0013
Revises: 0012
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision: str = "0013"
down_revision: str | None = "0012"
branch_labels: str | None = None
depends_on: str | None = None


def upgrade() -> None:
    """Add the column; fill it for tables of single-version rigs with a computed row."""
    with op.batch_alter_table("throttle_calibrations",
                              table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.add_column(sa.Column("rig_version", sa.Integer(), nullable=True))
    op.execute(
        "UPDATE throttle_calibrations SET rig_version = (SELECT MAX(v.version) FROM "
        "rig_versions v WHERE v.rig_id = throttle_calibrations.rig_id) WHERE "
        "(SELECT COUNT(*) FROM rig_versions v WHERE v.rig_id = throttle_calibrations.rig_id) "
        "= 1 AND EXISTS (SELECT 1 FROM calibration_points p WHERE p.calibration_id = "
        "throttle_calibrations.id AND p.clearance_origin = 'computed')")


def downgrade() -> None:
    """Drop the column (SQLite rebuilds the table, AUTOINCREMENT kept)."""
    with op.batch_alter_table("throttle_calibrations",
                              table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.drop_column("rig_version")
