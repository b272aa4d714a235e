"""Writes can carry an ``Idempotency-Key``: the table ``idempotent_requests``.

A client that timed out and sent its ``POST /diagnose`` again stored every record twice
(40 records → 80 rows); a resent series import stored the series twice and a resent
commissioning made a second rig version from the same records.  With the header, the
service keeps each key's request digest and, once it succeeded, its answer, and replays
that answer to a retry (:mod:`app.idempotency`).

Revision ID: 0010
Revises: 0009
Create Date: 2026-11-28
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from app.db.base import UTCDateTime

revision: str = "0010"
down_revision: str | None = "0009"
branch_labels: str | None = None
depends_on: str | None = None


def upgrade() -> None:
    """Create ``idempotent_requests``."""
    op.create_table(
        "idempotent_requests",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("owner", sa.String(64), nullable=False),
        sa.Column("idempotency_key", sa.String(255), nullable=False),
        sa.Column("method", sa.String(8), nullable=False),
        sa.Column("path", sa.String(500), nullable=False),
        sa.Column("digest", sa.String(64), nullable=False),
        sa.Column("status", sa.Integer(), nullable=True),
        sa.Column("content_type", sa.String(200), nullable=True),
        sa.Column("location", sa.String(500), nullable=True),
        sa.Column("body", sa.LargeBinary(), nullable=True),
        sa.Column("created_at", UTCDateTime(), nullable=False),
        sa.Column("touched_at", UTCDateTime(), nullable=False),
        sa.Column("expires_at", UTCDateTime(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_idempotent_requests")),
        sa.UniqueConstraint("owner", "idempotency_key",
                            name=op.f("uq_idempotent_requests_owner_idempotency_key")),
    )
    op.create_index(op.f("ix_idempotent_requests_expires_at"), "idempotent_requests",
                    ["expires_at"])


def downgrade() -> None:
    """Drop ``idempotent_requests``."""
    op.drop_index(op.f("ix_idempotent_requests_expires_at"), table_name="idempotent_requests")
    op.drop_table("idempotent_requests")
