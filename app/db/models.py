"""Tables of the store (SQLAlchemy 2 declarative mapping).

The migrations in ``app/migrations/versions`` create exactly these tables; a test compares
the migrated schema with this module, so the two cannot drift apart.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import (
    Boolean,
    CheckConstraint,
    Float,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    String,
    Text,
    UniqueConstraint,
)
from sqlalchemy.orm import Mapped, mapped_column, relationship

from app.db.base import Base, JSONDocument, UTCDateTime, utcnow

__all__ = [
    "JOB_STATUSES",
    "PUMP_SET_KINDS",
    "ApiKey",
    "CalibrationPoint",
    "ConsoleLogout",
    "Diagnosis",
    "DiagnosisEstimate",
    "DiagnosisRecord",
    "Job",
    "MeasuredSeries",
    "Measurement",
    "PumpSet",
    "Rig",
    "RigVersion",
    "ThrottleCalibration",
]

JOB_STATUSES = ("queued", "running", "succeeded", "failed")
#: Table option of every table with an integer key: SQLite never gives a deleted row's id
#: to a new one (``AUTOINCREMENT``; without it the highest freed id is reused, and a stored
#: diagnosis, job or link naming the deleted row would name the new one).  PostgreSQL's
#: sequences never reuse ids.  Revision 0007.
NO_ID_REUSE = {"sqlite_autoincrement": True}
PUMP_SET_KINDS = ("parameters", "loss_map")


class Rig(Base):
    """A hydraulic rig; its description lives in versions (:class:`RigVersion`)."""

    __tablename__ = "rigs"
    __table_args__ = NO_ID_REUSE

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    title: Mapped[str] = mapped_column(String(200))
    latest_version: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, onupdate=utcnow)

    versions: Mapped[list[RigVersion]] = relationship(
        back_populates="rig", cascade="all, delete-orphan", passive_deletes=True,
        order_by="RigVersion.version",
    )


class RigVersion(Base):
    """One immutable version of a rig description document."""

    __tablename__ = "rig_versions"
    __table_args__ = (UniqueConstraint("rig_id", "version"), NO_ID_REUSE)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    rig_id: Mapped[int] = mapped_column(ForeignKey("rigs.id", ondelete="CASCADE"))
    version: Mapped[int] = mapped_column(Integer)
    document: Mapped[dict[str, Any]] = mapped_column(JSONDocument)
    comment: Mapped[str | None] = mapped_column(String(500))
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)

    rig: Mapped[Rig] = relationship(back_populates="versions")


class ThrottleCalibration(Base):
    """Equivalence table of one leakage-simulating throttle valve (paper 002, §2.7)."""

    __tablename__ = "throttle_calibrations"
    __table_args__ = (
        UniqueConstraint(
            "rig_id", "throttle", "back_pressure_pa", "temperature_c",
            name="uq_throttle_calibrations_condition",
        ),
        NO_ID_REUSE,
    )

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    rig_id: Mapped[int] = mapped_column(ForeignKey("rigs.id", ondelete="CASCADE"), index=True)
    throttle: Mapped[str] = mapped_column(String(16))
    component: Mapped[str] = mapped_column(String(64))
    back_pressure_pa: Mapped[float] = mapped_column(Float)
    temperature_c: Mapped[float] = mapped_column(Float)
    source: Mapped[str | None] = mapped_column(Text)
    #: the rig version whose document computed the clearances; null: none computed (or
    #: not known, for a table stored before revision 0013 on a rig with several versions)
    rig_version: Mapped[int | None] = mapped_column(Integer)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, onupdate=utcnow)

    points: Mapped[list[CalibrationPoint]] = relationship(
        back_populates="calibration", cascade="all, delete-orphan", passive_deletes=True,
        order_by="CalibrationPoint.opening_turns",
    )


class CalibrationPoint(Base):
    """One row of a throttle equivalence table: opening → bypass flow → clearance."""

    __tablename__ = "calibration_points"
    __table_args__ = (
        UniqueConstraint("calibration_id", "opening_turns"),
        CheckConstraint("clearance_origin IN ('given', 'computed')", name="clearance_origin"),
        NO_ID_REUSE,
    )

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    calibration_id: Mapped[int] = mapped_column(
        ForeignKey("throttle_calibrations.id", ondelete="CASCADE")
    )
    opening_turns: Mapped[float] = mapped_column(Float)
    bypass_flow_m3s: Mapped[float] = mapped_column(Float)
    clearance_m: Mapped[float | None] = mapped_column(Float)
    clearance_origin: Mapped[str | None] = mapped_column(String(16))

    calibration: Mapped[ThrottleCalibration] = relationship(back_populates="points")


class PumpSet(Base):
    """A pump parameter set or loss map: named quantities, each with its unit."""

    __tablename__ = "pump_sets"
    __table_args__ = (CheckConstraint("kind IN ('parameters', 'loss_map')", name="kind"),
                      NO_ID_REUSE)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    kind: Mapped[str] = mapped_column(String(16))
    rig_id: Mapped[int | None] = mapped_column(
        ForeignKey("rigs.id", ondelete="SET NULL"), index=True
    )
    pump: Mapped[str] = mapped_column(String(200))
    source: Mapped[str | None] = mapped_column(Text)
    quantities: Mapped[dict[str, Any]] = mapped_column(JSONDocument)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, onupdate=utcnow)


class Measurement(Base):
    """A measurement record posted for a rig (the input of a diagnosis)."""

    __tablename__ = "measurements"
    __table_args__ = (Index(None, "rig_id", "measured_at"), NO_ID_REUSE)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    rig_id: Mapped[int] = mapped_column(ForeignKey("rigs.id", ondelete="RESTRICT"))
    measured_at: Mapped[datetime] = mapped_column(UTCDateTime())
    record: Mapped[dict[str, Any]] = mapped_column(JSONDocument)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)

    diagnoses: Mapped[list[Diagnosis]] = relationship(
        back_populates="measurement", cascade="all, delete-orphan", passive_deletes=True
    )
    #: every diagnosis made from this record: those kept with it and the joint ones it
    #: took part in (:class:`DiagnosisRecord`)
    diagnosed_in: Mapped[list[Diagnosis]] = relationship(
        secondary="diagnosis_records", viewonly=True, order_by="Diagnosis.id")


class MeasuredSeries(Base):
    """One imported time-series record of a rig (:mod:`diagnostics.timeseries`), in SI units.

    ``data`` holds ``{"t": [...] [s], "channels": {name: [...]}}``; ``units`` the SI unit of
    every channel; ``condition`` the record's constant operating condition; ``measured_at``
    the clock time of its first sample when the import stated one (null otherwise).
    """

    __tablename__ = "measured_series"
    __table_args__ = NO_ID_REUSE

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    rig_id: Mapped[int] = mapped_column(ForeignKey("rigs.id", ondelete="RESTRICT"), index=True)
    name: Mapped[str] = mapped_column(String(200))
    record: Mapped[str] = mapped_column(String(200))
    sample_rate: Mapped[float | None] = mapped_column(Float)
    n_samples: Mapped[int] = mapped_column(Integer)
    measured: Mapped[bool] = mapped_column(Boolean)
    units: Mapped[dict[str, Any]] = mapped_column(JSONDocument)
    condition: Mapped[dict[str, Any]] = mapped_column(JSONDocument)
    data: Mapped[dict[str, Any]] = mapped_column(JSONDocument)
    measured_at: Mapped[datetime | None] = mapped_column(UTCDateTime())
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)


class Diagnosis(Base):
    """The result of diagnosing one measurement against one rig version."""

    __tablename__ = "diagnoses"
    __table_args__ = NO_ID_REUSE

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    measurement_id: Mapped[int] = mapped_column(
        ForeignKey("measurements.id", ondelete="CASCADE"), index=True
    )
    rig_version_id: Mapped[int] = mapped_column(
        ForeignKey("rig_versions.id", ondelete="RESTRICT"), index=True
    )
    component: Mapped[str | None] = mapped_column(String(64))
    probability: Mapped[float | None] = mapped_column(Float)
    result: Mapped[dict[str, Any]] = mapped_column(JSONDocument)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    #: the diagnosis of the same records against a later rig version that replaced this one
    #: (``POST /rigs/{id}/rediagnose``, revision 0014); null while this one is current.  The
    #: key is checked at commit: a store copied in id order writes the old row first
    superseded_by: Mapped[int | None] = mapped_column(
        ForeignKey("diagnoses.id", ondelete="SET NULL", deferrable=True, initially="DEFERRED"),
        index=True)

    measurement: Mapped[Measurement] = relationship(back_populates="diagnoses")
    #: every record the diagnosis was made from (a joint one has several; its result is
    #: kept with one of them, :attr:`measurement`)
    records: Mapped[list[Measurement]] = relationship(
        secondary="diagnosis_records", order_by="Measurement.id")
    rig_version: Mapped[RigVersion] = relationship()
    estimates: Mapped[list[DiagnosisEstimate]] = relationship(
        back_populates="diagnosis", cascade="all, delete-orphan", passive_deletes=True
    )


class DiagnosisRecord(Base):
    """One record a diagnosis was made from (revision 0008): a joint diagnosis of a visit
    at three loads is linked to each of its three records, not only to the one its result
    is kept with, so that every record reads back the diagnoses it took part in."""

    __tablename__ = "diagnosis_records"

    diagnosis_id: Mapped[int] = mapped_column(
        ForeignKey("diagnoses.id", ondelete="CASCADE"), primary_key=True)
    measurement_id: Mapped[int] = mapped_column(
        ForeignKey("measurements.id", ondelete="CASCADE"), primary_key=True, index=True)


class DiagnosisEstimate(Base):
    """Estimated clearance or slip coefficient of one suspect component (the trend series)."""

    __tablename__ = "diagnosis_estimates"
    __table_args__ = (
        UniqueConstraint("diagnosis_id", "component"),
        Index(None, "component"),
        NO_ID_REUSE,
    )

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    diagnosis_id: Mapped[int] = mapped_column(ForeignKey("diagnoses.id", ondelete="CASCADE"))
    component: Mapped[str] = mapped_column(String(64))
    probability: Mapped[float | None] = mapped_column(Float)
    clearance_m: Mapped[float | None] = mapped_column(Float)
    slip_coefficient: Mapped[float | None] = mapped_column(Float)
    #: the 95 % interval the diagnosis stated for the estimate [m, or 1 for Cs]
    low: Mapped[float | None] = mapped_column(Float)
    high: Mapped[float | None] = mapped_column(Float)

    diagnosis: Mapped[Diagnosis] = relationship(back_populates="estimates")


class Job(Base):
    """A long piece of work (sweep, map, discrepancy run) with its progress and outcome."""

    __tablename__ = "jobs"
    __table_args__ = (
        CheckConstraint(
            "status IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')",
            name="status"
        ),
        CheckConstraint("progress >= 0 AND progress <= 1", name="progress"),
        Index(None, "status"),
    )

    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    kind: Mapped[str] = mapped_column(String(64))
    status: Mapped[str] = mapped_column(String(16))
    progress: Mapped[float] = mapped_column(Float)
    message: Mapped[str | None] = mapped_column(String(500))
    params: Mapped[dict[str, Any]] = mapped_column(JSONDocument)
    result: Mapped[dict[str, Any] | None] = mapped_column(JSONDocument)
    error: Mapped[dict[str, Any] | None] = mapped_column(JSONDocument)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    started_at: Mapped[datetime | None] = mapped_column(UTCDateTime())
    finished_at: Mapped[datetime | None] = mapped_column(UTCDateTime())
    updated_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, onupdate=utcnow)
    #: when a cancel was asked of the job while it ran (it stops at its next progress
    #: report, :class:`app.services.jobs.Progress`)
    cancel_requested_at: Mapped[datetime | None] = mapped_column(UTCDateTime())
    #: the process running the job (host:pid:token of its :class:`app.services.jobs.JobRunner`)
    #: and until when it holds the job: it renews the lease while the job is queued or
    #: running; another process fails the job only once the lease has run out (revision 0009)
    owner: Mapped[str | None] = mapped_column(String(64))
    lease_until: Mapped[datetime | None] = mapped_column(UTCDateTime())


class ApiKey(Base):
    """An API key: only a salted scrypt hash of the secret is kept."""

    __tablename__ = "api_keys"
    __table_args__ = NO_ID_REUSE

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    prefix: Mapped[str] = mapped_column(String(16), unique=True)
    key_hash: Mapped[str] = mapped_column(String(255))
    #: ``read``, ``write`` or ``admin`` (:class:`app.security.Scope`); keys made before
    #: scopes existed (revision 0004) are ``admin``, as they could do everything.
    scope: Mapped[str] = mapped_column(String(8), server_default="admin")
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    #: When the key stops working: the moment of revocation, or the end of the grace
    #: period of a rotated key (in the future until then).
    revoked_at: Mapped[datetime | None] = mapped_column(UTCDateTime())
    #: The first key of its rotation chain (``None``: this key is), which owns the chain's
    #: ``Idempotency-Key`` rows, so that a retry across a rotation is the same client's
    #: (revision 0011).
    lineage_id: Mapped[int | None] = mapped_column(Integer)


class ConsoleLogout(Base):
    """A console session its logout ended (revision 0015): the digest (SHA-256) of the
    session cookie, refused until the cookie would have expired anyway (``expires_at``,
    then the row is removed).  The cookie is signed and stateless, so deleting it in the
    browser did not end a copy of it (a security review)."""

    __tablename__ = "console_logouts"
    __table_args__ = (UniqueConstraint("digest"), Index(None, "expires_at"))

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    digest: Mapped[str] = mapped_column(String(64))
    expires_at: Mapped[datetime] = mapped_column(UTCDateTime())


class IdempotentRequest(Base):
    """A write sent with an ``Idempotency-Key`` header and, once it succeeded, its answer
    (:mod:`app.idempotency`; revision 0010).

    ``owner`` is a digest of the rotation chain of the API key that sent it (keys of
    different clients never share a row; a key and the key that replaced it do, revision
    0011); ``digest`` one of the request (method, path, query, content type, body), so
    that the same key on another request is refused; ``status`` is ``None`` while the
    first request is being processed.  ``stored_at`` is set in the transaction that stored
    the request's work (revision 0011), so a retry after a process died between that
    commit and keeping the answer is not run again.  Rows expire (``expires_at``) and are
    removed.
    """

    __tablename__ = "idempotent_requests"
    __table_args__ = (UniqueConstraint("owner", "idempotency_key"), Index(None, "expires_at"))

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    owner: Mapped[str] = mapped_column(String(64))
    idempotency_key: Mapped[str] = mapped_column(String(255))
    method: Mapped[str] = mapped_column(String(8))
    path: Mapped[str] = mapped_column(String(500))
    digest: Mapped[str] = mapped_column(String(64))
    status: Mapped[int | None] = mapped_column(Integer)
    content_type: Mapped[str | None] = mapped_column(String(200))
    location: Mapped[str | None] = mapped_column(String(500))
    body: Mapped[bytes | None] = mapped_column(LargeBinary)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    #: last time the process running the first request marked it as in hand
    touched_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    expires_at: Mapped[datetime] = mapped_column(UTCDateTime())
    #: when the transaction that stored the request's work committed (``None``: not yet)
    stored_at: Mapped[datetime | None] = mapped_column(UTCDateTime())
