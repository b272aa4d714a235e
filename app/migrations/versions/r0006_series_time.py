"""A measured series keeps the clock time of its first sample: ``measured_series.measured_at``.

Given at import (``started_at``: the form field, the CLI option or the file's header), it
puts a cycle read from the series on the history's time axis where it was measured, not
where it was diagnosed.  Series imported before have none (null).

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-27
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from app.db.base import UTCDateTime

revision: str = "0006"
down_revision: str | None = "0005"
branch_labels: str | None = None
depends_on: str | None = None


def upgrade() -> None:
    """Add ``measured_series.measured_at``."""
    with op.batch_alter_table("measured_series") as batch:
        batch.add_column(sa.Column("measured_at", UTCDateTime(), nullable=True))


def downgrade() -> None:
    """Drop ``measured_series.measured_at``."""
    with op.batch_alter_table("measured_series") as batch:
        batch.drop_column("measured_at")
