"""Console logout ends the session on the server: ``console_logouts``.

The console's login cookie is signed and stateless (``<key id>.<issued at>.<HMAC>``):
logout deleted it in the browser, and a copy of it kept working until it expired (12 h)
or its key was revoked (a security review, left open since stop 50).  Logout now keeps
the SHA-256 of the cookie until the moment it would have expired; a cookie found there is
refused.  Expired rows are removed at each logout.

Revision ID: 0015
Revises: 0014
Create Date: 2026-11-30
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from app.db.base import UTCDateTime

revision: str = "0015"
down_revision: str | None = "0014"
branch_labels: str | None = None
depends_on: str | None = None


def upgrade() -> None:
    """Create ``console_logouts``."""
    op.create_table(
        "console_logouts",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("digest", sa.String(64), nullable=False),
        sa.Column("expires_at", UTCDateTime(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_console_logouts")),
        sa.UniqueConstraint("digest", name=op.f("uq_console_logouts_digest")),
    )
    op.create_index(op.f("ix_console_logouts_expires_at"), "console_logouts", ["expires_at"])


def downgrade() -> None:
    """Drop ``console_logouts`` (sessions logged out work again below 0015 until they
    expire)."""
    op.drop_index(op.f("ix_console_logouts_expires_at"), table_name="console_logouts")
    op.drop_table("console_logouts")
