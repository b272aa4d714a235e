"""Measured time series of a rig (issue 12): the table ``measured_series``.

Revision ID: 0003
Revises: 0001
Create Date: 2026-11-23
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from app.db.base import JSONDocument, UTCDateTime

revision: str = "0003"
down_revision: str | None = "0001"
branch_labels: str | None = None
depends_on: str | None = None


def upgrade() -> None:
    """Create ``measured_series``."""
    op.create_table(
        "measured_series",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("rig_id", sa.Integer(), nullable=False),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("record", sa.String(200), nullable=False),
        sa.Column("sample_rate", sa.Float(), nullable=True),
        sa.Column("n_samples", sa.Integer(), nullable=False),
        sa.Column("measured", sa.Boolean(), nullable=False),
        sa.Column("units", JSONDocument, nullable=False),
        sa.Column("condition", JSONDocument, nullable=False),
        sa.Column("data", JSONDocument, nullable=False),
        sa.Column("created_at", UTCDateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["rig_id"], ["rigs.id"], ondelete="RESTRICT",
            name=op.f("fk_measured_series_rig_id_rigs"),
        ),
    )
    op.create_index(op.f("ix_measured_series_rig_id"), "measured_series", ["rig_id"])


def downgrade() -> None:
    """Drop ``measured_series``."""
    op.drop_index(op.f("ix_measured_series_rig_id"), table_name="measured_series")
    op.drop_table("measured_series")
