"""Every record a diagnosis was made from: ``diagnosis_records``.

A joint diagnosis (one visit at several loads) was linked only to the record its result
is kept with (``diagnoses.measurement_id``): the visit's other records read back no
diagnosis, and ``GET /diagnoses/{id}`` named one record of three.  The new table links a
diagnosis to each of its records; existing diagnoses are linked to the record they are
kept with (which records a stored joint diagnosis also used was not kept, so those links
cannot be made).

Revision ID: 0008
Revises: 0007
Create Date: 2026-11-28
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision: str = "0008"
down_revision: str | None = "0007"
branch_labels: str | None = None
depends_on: str | None = None


def upgrade() -> None:
    """Create ``diagnosis_records`` and link every diagnosis to its own record."""
    op.create_table(
        "diagnosis_records",
        sa.Column("diagnosis_id", sa.Integer(), nullable=False),
        sa.Column("measurement_id", sa.Integer(), nullable=False),
        sa.ForeignKeyConstraint(["diagnosis_id"], ["diagnoses.id"], ondelete="CASCADE",
                                name=op.f("fk_diagnosis_records_diagnosis_id_diagnoses")),
        sa.ForeignKeyConstraint(["measurement_id"], ["measurements.id"], ondelete="CASCADE",
                                name=op.f("fk_diagnosis_records_measurement_id_measurements")),
        sa.PrimaryKeyConstraint("diagnosis_id", "measurement_id",
                                name=op.f("pk_diagnosis_records")),
    )
    op.create_index(op.f("ix_diagnosis_records_measurement_id"), "diagnosis_records",
                    ["measurement_id"])
    op.execute("INSERT INTO diagnosis_records (diagnosis_id, measurement_id) "
               "SELECT id, measurement_id FROM diagnoses")


def downgrade() -> None:
    """Drop ``diagnosis_records``."""
    op.drop_index(op.f("ix_diagnosis_records_measurement_id"), table_name="diagnosis_records")
    op.drop_table("diagnosis_records")
