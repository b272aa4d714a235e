"""Scopes of API keys (issue 14): the column ``api_keys.scope``.

Every key made before this revision could do everything, so each existing key becomes an
``admin`` key (the column's server default fills them in).  New keys are made with an
explicit scope (``hydrodiag keys create --scope read|write|admin``).

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-23
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision: str = "0004"
down_revision: str | None = "0003"
branch_labels: str | None = None
depends_on: str | None = None


def upgrade() -> None:
    """Add ``api_keys.scope``; existing keys become ``admin``."""
    with op.batch_alter_table("api_keys") as batch:
        batch.add_column(sa.Column("scope", sa.String(8), nullable=False,
                                   server_default="admin"))


def downgrade() -> None:
    """Drop ``api_keys.scope`` (every key can then do everything again)."""
    with op.batch_alter_table("api_keys") as batch:
        batch.drop_column("scope")
