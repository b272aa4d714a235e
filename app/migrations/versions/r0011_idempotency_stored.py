"""An ``Idempotency-Key`` knows when its work was stored, and belongs to a key's lineage:
``idempotent_requests.stored_at`` and ``api_keys.lineage_id``.

A server killed after a keyed write had committed but before its answer was kept let the
retry run the write again (an operator's kill -9 under load doubled 2 of ~4 requests in
flight), and a retry sent with the key that replaced a rotated one was a new request and
stored again.  ``stored_at`` is set in the transaction that stores the work
(:mod:`app.services.idempotent_work`); ``lineage_id`` is the id of the first key of a
rotation chain (``NULL``: the key's own id), which owns its idempotency keys.

Revision ID: 0011
Revises: 0010
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from app.db.base import UTCDateTime

revision: str = "0011"
down_revision: str | None = "0010"
branch_labels: str | None = None
depends_on: str | None = None


def upgrade() -> None:
    """Add ``idempotent_requests.stored_at`` and ``api_keys.lineage_id``."""
    with op.batch_alter_table("idempotent_requests") as batch:
        batch.add_column(sa.Column("stored_at", UTCDateTime(), nullable=True))
    with op.batch_alter_table("api_keys") as batch:
        batch.add_column(sa.Column("lineage_id", sa.Integer(), nullable=True))


def downgrade() -> None:
    """Drop the two columns."""
    with op.batch_alter_table("api_keys") as batch:
        batch.drop_column("lineage_id")
    with op.batch_alter_table("idempotent_requests") as batch:
        batch.drop_column("stored_at")
