"""Jobs: long work (sweeps, maps, discrepancy runs) with id, status and progress."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import Field

from app.schemas.common import Page, PublicModel, error_doc
from app.schemas.times import Timestamp

__all__ = ["QUEUE_FULL", "JobList", "JobPublic", "JobStatus"]

JobStatus = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class JobPublic(PublicModel):
    """A job's state; ``result`` is filled when it succeeded, ``error`` when it failed or
    was cancelled."""

    id: str = Field(
        description="Job identifier (UUID) [-]", examples=["1b4e28ba-2fa1-11d2-883f-0016d3cca427"]
    )
    kind: str = Field(description="What the job does [-]", examples=["sweep"])
    status: JobStatus = Field(description="Where the job is [-]", examples=["running"])
    progress: float = Field(
        ge=0, le=1, description="Fraction of the work done [1]", examples=[0.35]
    )
    message: str | None = Field(
        description="Latest progress note [-]", examples=["case 35 of 100"]
    )
    params: dict[str, Any] = Field(
        description="Parameters the job was started with, units as in its request [-]",
        examples=[{"rig_id": 1, "clearances_m": [4e-5, 8e-5]}],
    )
    result: dict[str, Any] | None = Field(
        description="Outcome of a succeeded job, units as documented by its kind [-]",
        examples=[None],
    )
    error: dict[str, Any] | None = Field(
        description="Why a failed job failed, as {type, message, field} [-]",
        examples=[{"type": "SimulationError", "message": "step size underflow", "field": None}],
    )
    created_at: Timestamp
    started_at: datetime | None = Field(
        description="When a worker took the job [UTC]", examples=["2026-11-22T08:30:01Z"]
    )
    finished_at: datetime | None = Field(
        description="When the job succeeded, failed or was cancelled [UTC]", examples=[None]
    )
    cancel_requested_at: datetime | None = Field(
        description="When a cancel was asked of the job while it ran; it stops at its next "
        "progress report [UTC]", examples=[None]
    )
    owner: str | None = Field(
        default=None, description="The server process that runs the job, "
        "host:pid:token [-] (none for jobs stored before revision 0009)",
        examples=["hd-1:4711:9f3c2a1b"])
    lease_until: datetime | None = Field(
        default=None, description="Until when that process holds the job; it renews the "
        "lease while the job is queued or running, and a job whose lease ran out is marked "
        "failed by any process of the store [UTC]", examples=["2026-11-22T08:31:01Z"])


class JobList(Page[JobPublic]):
    """A page of jobs, newest first."""

    results: bool = Field(
        default=False, description="Whether each item's `result` is given (query `results`); "
        "false: null, read it from GET /jobs/{id} [-]", examples=[False])


def job_summary(job: Any) -> JobPublic:
    """``job`` as :class:`JobPublic` without its result (``result`` null; the column is not
    read)."""
    fields = {name: getattr(job, name) for name in JobPublic.model_fields if name != "result"}
    return JobPublic.model_validate(fields | {"result": None})


#: the 503 of an operation that starts a job: the server process has as many as it takes
QUEUE_FULL = error_doc(
    "As many jobs running and waiting in this server process as it takes "
    "(HYDRODIAG_JOB_WORKERS running, HYDRODIAG_MAX_QUEUED_JOBS waiting), or the store does "
    "not answer now; nothing was stored; retry after Retry-After")
