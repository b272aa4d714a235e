"""A diagnosis replaced by a re-diagnosis against a later rig version says so:
``diagnoses.superseded_by`` (the id of the diagnosis that replaced it; null while current).

A maintenance planner commissioned a new rig version (seal length × 0.85): the trend left
out every earlier point, and the only way back was to post each old record again, which
stored a second diagnosis per record and showed the history twice.  ``POST
/rigs/{id}/rediagnose`` diagnoses the stored records again against the latest version and
marks the old diagnoses superseded; listings and trends read the current ones.  Diagnoses
stored before are all current, except those a re-diagnosis names as replaced
(``result["rediagnosis_of"]``): a store taken back below this revision (``db downgrade``)
and migrated again had lost every mark, and history and trends counted each re-diagnosed
visit twice (an upgrade pass); the marks are rebuilt from the results.

Revision ID: 0014
Revises: 0013
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from app.db.base import JSONDocument

revision: str = "0014"
down_revision: str | None = "0013"
branch_labels: str | None = None
depends_on: str | None = None

#: diagnoses read per statement while the marks are rebuilt
BATCH = 1000


def upgrade() -> None:
    """Add the column, its foreign key to ``diagnoses.id`` (set null when the replacing
    diagnosis goes; checked at commit, so that a store copied in id order can write the
    old row before the one that replaced it) and its index."""
    with op.batch_alter_table("diagnoses", table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.add_column(sa.Column("superseded_by", sa.Integer(), nullable=True))
        batch.create_foreign_key("fk_diagnoses_superseded_by_diagnoses", "diagnoses",
                                 ["superseded_by"], ["id"], ondelete="SET NULL",
                                 deferrable=True, initially="DEFERRED")
        batch.create_index("ix_diagnoses_superseded_by", ["superseded_by"])
    diagnoses = sa.table("diagnoses", sa.column("id", sa.Integer),
                         sa.column("result", JSONDocument),
                         sa.column("superseded_by", sa.Integer))
    connection = op.get_bind()
    update = (sa.update(diagnoses).where(diagnoses.c.id == sa.bindparam("old"))
              .values(superseded_by=sa.bindparam("new")))
    last = 0
    while True:
        rows = connection.execute(sa.select(diagnoses.c.id, diagnoses.c.result)
                                  .where(diagnoses.c.id > last).order_by(diagnoses.c.id)
                                  .limit(BATCH)).all()
        if not rows:
            break
        last = int(rows[-1][0])
        marks = [{"old": int(result["rediagnosis_of"]), "new": int(i)} for i, result in rows
                 if isinstance(result, dict) and isinstance(result.get("rediagnosis_of"), int)
                 and not isinstance(result.get("rediagnosis_of"), bool)]
        if marks:
            connection.execute(update, marks)


def downgrade() -> None:
    """Drop the index, the key and the column (SQLite rebuilds the table, AUTOINCREMENT
    kept)."""
    with op.batch_alter_table("diagnoses", table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.drop_index("ix_diagnoses_superseded_by")
        batch.drop_constraint("fk_diagnoses_superseded_by_diagnoses", type_="foreignkey")
        batch.drop_column("superseded_by")
