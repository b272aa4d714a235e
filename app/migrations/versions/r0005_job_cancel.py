"""Jobs can be cancelled (``POST /jobs/{id}/cancel``): the status ``cancelled`` and the
column ``jobs.cancel_requested_at``.

A queued job is cancelled at once; a running one is asked to stop
(``cancel_requested_at`` set) and stops at its next progress report
(:class:`app.services.jobs.Progress`).  Existing jobs keep their status and have no
request.

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-27
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from app.db.base import UTCDateTime

revision: str = "0005"
down_revision: str | None = "0004"
branch_labels: str | None = None
depends_on: str | None = None

_BEFORE = "status IN ('queued', 'running', 'succeeded', 'failed')"
_AFTER = "status IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')"


def upgrade() -> None:
    """Allow ``cancelled``; add ``jobs.cancel_requested_at``."""
    with op.batch_alter_table("jobs") as batch:
        batch.drop_constraint(op.f("ck_jobs_status"), type_="check")
        batch.create_check_constraint(op.f("ck_jobs_status"), sa.text(_AFTER))
        batch.add_column(sa.Column("cancel_requested_at", UTCDateTime(), nullable=True))


def downgrade() -> None:
    """Cancelled jobs become failed ones (with their error); drop the column."""
    op.execute("UPDATE jobs SET status = 'failed' WHERE status = 'cancelled'")
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("cancel_requested_at")
        batch.drop_constraint(op.f("ck_jobs_status"), type_="check")
        batch.create_check_constraint(op.f("ck_jobs_status"), sa.text(_BEFORE))
