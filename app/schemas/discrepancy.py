"""Discrepancy runs: ``POST /discrepancy`` (form fields + a measured time-series file)."""

from __future__ import annotations

from pydantic import BaseModel, Field

from app.schemas.common import MAX_ID, UploadForm

__all__ = ["DiscrepancyAccepted", "DiscrepancyForm"]


class DiscrepancyForm(UploadForm):
    """Form fields sent with the measured time series.

    The file part is let through and other unknown fields refused
    (:class:`~app.schemas.common.UploadForm`).
    """

    rig_id: int = Field(ge=1, le=MAX_ID, description="Stored rig whose model is checked [-]",
                        examples=[1])
    rig_version: int | None = Field(default=None, ge=1, le=MAX_ID,
                                    description="Version of the rig document; the latest when "
                                    "null [-]", examples=[None])
    refit: bool = Field(default=True, description="Re-fit named effects in output-error form "
                        "by re-simulation [-]", examples=[True])
    store: bool = Field(default=True, description="Store the augmented rig as a new version "
                        "of the rig when an effect is named [-]", examples=[True])


class DiscrepancyAccepted(BaseModel):
    """A discrepancy run started as a job; follow it at ``/jobs/{job_id}``."""

    job_id: str = Field(description="Job identifier (UUID) [-]",
                        examples=["1b4e28ba-2fa1-11d2-883f-0016d3cca427"])
    status: str = Field(description="Job state [-]", examples=["queued"])
    records: list[str] = Field(description="Names of the records read from the file [-]",
                               examples=[["load-2100", "load-4200"]])
    channels: list[str] = Field(description="Measured channels found (SI units inside) [-]",
                                examples=[["P1", "P2", "v"]])
