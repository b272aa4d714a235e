"""Initial schema: rigs and versions, throttle calibrations, pump sets, history, jobs, keys.

Revision ID: 0001
Revises:
Create Date: 2026-11-22
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from app.db.base import JSONDocument, UTCDateTime

revision: str = "0001"
down_revision: str | None = None
branch_labels: str | None = None
depends_on: str | None = None


def _timestamps(*names: str, nullable: bool = False) -> list[sa.Column[object]]:
    return [sa.Column(name, UTCDateTime(), nullable=nullable) for name in names]


def upgrade() -> None:
    """Create every table of the store."""
    op.create_table(
        "rigs",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(100), nullable=False),
        sa.Column("title", sa.String(200), nullable=False),
        sa.Column("latest_version", sa.Integer(), nullable=False),
        *_timestamps("created_at", "updated_at"),
        sa.UniqueConstraint("name", name=op.f("uq_rigs_name")),
    )
    op.create_table(
        "rig_versions",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("rig_id", sa.Integer(), nullable=False),
        sa.Column("version", sa.Integer(), nullable=False),
        sa.Column("document", JSONDocument, nullable=False),
        sa.Column("comment", sa.String(500), nullable=True),
        *_timestamps("created_at"),
        sa.ForeignKeyConstraint(
            ["rig_id"], ["rigs.id"], ondelete="CASCADE",
            name=op.f("fk_rig_versions_rig_id_rigs"),
        ),
        sa.UniqueConstraint("rig_id", "version", name=op.f("uq_rig_versions_rig_id_version")),
    )
    op.create_table(
        "throttle_calibrations",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("rig_id", sa.Integer(), nullable=False),
        sa.Column("throttle", sa.String(16), nullable=False),
        sa.Column("component", sa.String(64), nullable=False),
        sa.Column("back_pressure_pa", sa.Float(), nullable=False),
        sa.Column("temperature_c", sa.Float(), nullable=False),
        sa.Column("source", sa.Text(), nullable=True),
        *_timestamps("created_at", "updated_at"),
        sa.ForeignKeyConstraint(
            ["rig_id"], ["rigs.id"], ondelete="CASCADE",
            name=op.f("fk_throttle_calibrations_rig_id_rigs"),
        ),
        sa.UniqueConstraint(
            "rig_id", "throttle", "back_pressure_pa", "temperature_c",
            name=op.f("uq_throttle_calibrations_condition"),
        ),
    )
    op.create_index(
        op.f("ix_throttle_calibrations_rig_id"), "throttle_calibrations", ["rig_id"]
    )
    op.create_table(
        "calibration_points",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("calibration_id", sa.Integer(), nullable=False),
        sa.Column("opening_turns", sa.Float(), nullable=False),
        sa.Column("bypass_flow_m3s", sa.Float(), nullable=False),
        sa.Column("clearance_m", sa.Float(), nullable=True),
        sa.Column("clearance_origin", sa.String(16), nullable=True),
        sa.ForeignKeyConstraint(
            ["calibration_id"], ["throttle_calibrations.id"], ondelete="CASCADE",
            name=op.f("fk_calibration_points_calibration_id_throttle_calibrations"),
        ),
        sa.UniqueConstraint(
            "calibration_id", "opening_turns",
            name=op.f("uq_calibration_points_calibration_id_opening_turns"),
        ),
        sa.CheckConstraint(
            "clearance_origin IN ('given', 'computed')",
            name=op.f("ck_calibration_points_clearance_origin"),
        ),
    )
    op.create_table(
        "pump_sets",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(100), nullable=False),
        sa.Column("kind", sa.String(16), nullable=False),
        sa.Column("rig_id", sa.Integer(), nullable=True),
        sa.Column("pump", sa.String(200), nullable=False),
        sa.Column("source", sa.Text(), nullable=True),
        sa.Column("quantities", JSONDocument, nullable=False),
        *_timestamps("created_at", "updated_at"),
        sa.ForeignKeyConstraint(
            ["rig_id"], ["rigs.id"], ondelete="SET NULL",
            name=op.f("fk_pump_sets_rig_id_rigs"),
        ),
        sa.UniqueConstraint("name", name=op.f("uq_pump_sets_name")),
        sa.CheckConstraint(
            "kind IN ('parameters', 'loss_map')", name=op.f("ck_pump_sets_kind")
        ),
    )
    op.create_index(op.f("ix_pump_sets_rig_id"), "pump_sets", ["rig_id"])
    op.create_table(
        "measurements",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("rig_id", sa.Integer(), nullable=False),
        sa.Column("measured_at", UTCDateTime(), nullable=False),
        sa.Column("record", JSONDocument, nullable=False),
        *_timestamps("created_at"),
        sa.ForeignKeyConstraint(
            ["rig_id"], ["rigs.id"], ondelete="RESTRICT",
            name=op.f("fk_measurements_rig_id_rigs"),
        ),
    )
    op.create_index(
        op.f("ix_measurements_rig_id"), "measurements", ["rig_id", "measured_at"]
    )
    op.create_table(
        "diagnoses",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("measurement_id", sa.Integer(), nullable=False),
        sa.Column("rig_version_id", sa.Integer(), nullable=False),
        sa.Column("component", sa.String(64), nullable=True),
        sa.Column("probability", sa.Float(), nullable=True),
        sa.Column("result", JSONDocument, nullable=False),
        *_timestamps("created_at"),
        sa.ForeignKeyConstraint(
            ["measurement_id"], ["measurements.id"], ondelete="CASCADE",
            name=op.f("fk_diagnoses_measurement_id_measurements"),
        ),
        sa.ForeignKeyConstraint(
            ["rig_version_id"], ["rig_versions.id"], ondelete="RESTRICT",
            name=op.f("fk_diagnoses_rig_version_id_rig_versions"),
        ),
    )
    op.create_index(op.f("ix_diagnoses_measurement_id"), "diagnoses", ["measurement_id"])
    op.create_index(op.f("ix_diagnoses_rig_version_id"), "diagnoses", ["rig_version_id"])
    op.create_table(
        "diagnosis_estimates",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("diagnosis_id", sa.Integer(), nullable=False),
        sa.Column("component", sa.String(64), nullable=False),
        sa.Column("probability", sa.Float(), nullable=True),
        sa.Column("clearance_m", sa.Float(), nullable=True),
        sa.Column("slip_coefficient", sa.Float(), nullable=True),
        sa.ForeignKeyConstraint(
            ["diagnosis_id"], ["diagnoses.id"], ondelete="CASCADE",
            name=op.f("fk_diagnosis_estimates_diagnosis_id_diagnoses"),
        ),
        sa.UniqueConstraint(
            "diagnosis_id", "component",
            name=op.f("uq_diagnosis_estimates_diagnosis_id_component"),
        ),
    )
    op.create_index(
        op.f("ix_diagnosis_estimates_component"), "diagnosis_estimates", ["component"]
    )
    op.create_table(
        "jobs",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("kind", sa.String(64), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("progress", sa.Float(), nullable=False),
        sa.Column("message", sa.String(500), nullable=True),
        sa.Column("params", JSONDocument, nullable=False),
        sa.Column("result", JSONDocument, nullable=True),
        sa.Column("error", JSONDocument, nullable=True),
        *_timestamps("created_at"),
        *_timestamps("started_at", "finished_at", nullable=True),
        *_timestamps("updated_at"),
        sa.CheckConstraint(
            "status IN ('queued', 'running', 'succeeded', 'failed')",
            name=op.f("ck_jobs_status"),
        ),
        sa.CheckConstraint("progress >= 0 AND progress <= 1", name=op.f("ck_jobs_progress")),
    )
    op.create_index(op.f("ix_jobs_status"), "jobs", ["status"])
    op.create_table(
        "api_keys",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(100), nullable=False),
        sa.Column("prefix", sa.String(16), nullable=False),
        sa.Column("key_hash", sa.String(255), nullable=False),
        *_timestamps("created_at"),
        *_timestamps("revoked_at", nullable=True),
        sa.UniqueConstraint("name", name=op.f("uq_api_keys_name")),
        sa.UniqueConstraint("prefix", name=op.f("uq_api_keys_prefix")),
    )


def downgrade() -> None:
    """Drop every table of the store, dependents first."""
    for table in (
        "api_keys", "jobs", "diagnosis_estimates", "diagnoses", "measurements", "pump_sets",
        "calibration_points", "throttle_calibrations", "rig_versions", "rigs",
    ):
        op.drop_table(table)
