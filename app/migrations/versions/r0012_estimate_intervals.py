"""Each stored estimate keeps the 95 % interval its diagnosis stated:
``diagnosis_estimates.low`` and ``.high`` [m, or 1 for Cs].

A trend read every point's interval out of its diagnosis's stored result (a JSON document
of ~15 KB): at 12,600 diagnoses that was a third of a trends request (0.2 of 0.6 s; an
operator pass's store).  The columns are filled here from those results
(``result["estimates"][component]["low"/"high"]``; ``NULL`` where a result has none).

Revision ID: 0012
Revises: 0011
Create Date: 2026-11-29
"""

from __future__ import annotations

from typing import Any

import sqlalchemy as sa
from alembic import op

from app.db.base import JSONDocument

revision: str = "0012"
down_revision: str | None = "0011"
branch_labels: str | None = None
depends_on: str | None = None

#: estimates filled per statement
BATCH = 1000


def _bound(result: Any, component: str, bound: str) -> float | None:
    estimates = result.get("estimates") if isinstance(result, dict) else None
    entry = estimates.get(component) if isinstance(estimates, dict) else None
    value = entry.get(bound) if isinstance(entry, dict) else None
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


def upgrade() -> None:
    """Add the two columns and fill them from the stored results."""
    with op.batch_alter_table("diagnosis_estimates") as batch:
        batch.add_column(sa.Column("low", sa.Float(), nullable=True))
        batch.add_column(sa.Column("high", sa.Float(), nullable=True))
    estimates = sa.table("diagnosis_estimates", sa.column("id", sa.Integer),
                         sa.column("diagnosis_id", sa.Integer),
                         sa.column("component", sa.String),
                         sa.column("low", sa.Float), sa.column("high", sa.Float))
    diagnoses = sa.table("diagnoses", sa.column("id", sa.Integer),
                         sa.column("result", JSONDocument))
    connection = op.get_bind()
    update = (sa.update(estimates).where(estimates.c.id == sa.bindparam("row"))
              .values(low=sa.bindparam("lo"), high=sa.bindparam("hi")))
    last = 0
    while True:
        rows = connection.execute(
            sa.select(estimates.c.id, estimates.c.component, diagnoses.c.result)
            .join(diagnoses, diagnoses.c.id == estimates.c.diagnosis_id)
            .where(estimates.c.id > last).order_by(estimates.c.id).limit(BATCH)).all()
        if not rows:
            break
        last = int(rows[-1][0])
        values = [{"row": int(i), "lo": _bound(result, component, "low"),
                   "hi": _bound(result, component, "high")} for i, component, result in rows]
        values = [v for v in values if v["lo"] is not None or v["hi"] is not None]
        if values:
            connection.execute(update, values)


def downgrade() -> None:
    """Drop the two columns (SQLite rebuilds the table: with AUTOINCREMENT kept, revision
    0007's no-id-reuse, which a plain rebuild dropped; an operator pass)."""
    with op.batch_alter_table("diagnosis_estimates",
                              table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.drop_column("high")
        batch.drop_column("low")
