"""Jobs are owned by the process that runs them and hold a lease it renews:
``jobs.owner`` and ``jobs.lease_until``.

A service starting on a store marked every queued or running job of the store failed, so a
second instance (or a restarted replica, or a respawned worker) on one database failed the
jobs another instance was running and threw away their results.  Now a job is failed only
once its lease has run out (:func:`app.services.jobs.fail_interrupted_jobs`).  Existing
jobs have no owner and no lease: one still queued or running is one of a stopped service.

Revision ID: 0009
Revises: 0008
Create Date: 2026-11-28
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from app.db.base import UTCDateTime

revision: str = "0009"
down_revision: str | None = "0008"
branch_labels: str | None = None
depends_on: str | None = None


def upgrade() -> None:
    """Add ``jobs.owner`` and ``jobs.lease_until``."""
    with op.batch_alter_table("jobs") as batch:
        batch.add_column(sa.Column("owner", sa.String(64), nullable=True))
        batch.add_column(sa.Column("lease_until", UTCDateTime(), nullable=True))


def downgrade() -> None:
    """Drop the two columns."""
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("lease_until")
        batch.drop_column("owner")
