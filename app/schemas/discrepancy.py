"""Discrepancy runs: ``POST /discrepancy`` (form fields + a measured file or stored series)."""

from __future__ import annotations

from pydantic import BaseModel, Field

from app.schemas.common import MAX_ID, FiniteFloat, UploadForm
from diagnostics.real.relaxation import MAX_RELAXATION, ZEMA_RELAXATION
from diagnostics.timeseries import MAX_SAMPLE_RATE

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
    series_ids: str | None = Field(
        default=None, pattern=r"^\s*[1-9][0-9]{0,17}\s*(,\s*[1-9][0-9]{0,17}\s*){0,199}$",
        description="Stored measured records of the rig (POST /rigs/{rig_id}/series) to check "
        "instead of a file: their ids, comma-separated, at most 200, e.g. '3,4,5' [-]",
        examples=[None])

    column_map: str | None = Field(
        default=None, max_length=20000,
        description="A logger's own layout for the file's columns, as the series import takes "
        "it: JSON raw column → [channel, unit] (or [channel, unit, gain, offset]), "
        "['record', '-'], ['phase', '-'] or ['skip', '-'] [-]", examples=[None])
    sample_rate: FiniteFloat | None = Field(
        default=None, gt=0, le=MAX_SAMPLE_RATE,
        description="Samples per second of a file without a time column [Hz]",
        examples=[None])

    relaxation: FiniteFloat = Field(
        default=ZEMA_RELAXATION, ge=0.0, le=MAX_RELAXATION,
        description="For stored records of a rig without a working/return cycle (the "
        "pump-relief-orifice circuit): the settling time after which each pressure plateau's "
        "flow is read, the records' settled plateaus then checked as a pump-bench table; "
        "3.5 s was found on the ZeMA cycles without labels [s]", examples=[ZEMA_RELAXATION])

    def ids(self) -> list[int]:
        """The ids of ``series_ids`` in the order given (empty when none)."""
        return [int(x) for x in self.series_ids.split(",")] if self.series_ids else []


class DiscrepancyAccepted(BaseModel):
    """A discrepancy run started as a job; follow it at ``/jobs/{job_id}``."""

    job_id: str = Field(description="Job identifier (UUID) [-]",
                        examples=["1b4e28ba-2fa1-11d2-883f-0016d3cca427"])
    status: str = Field(description="Job state [-]", examples=["queued"])
    records: list[str] = Field(description="Names of the records read from the file [-]",
                               examples=[["load-2100", "load-4200"]])
    channels: list[str] = Field(description="Measured channels found (SI units inside) [-]",
                                examples=[["P1", "P2", "v"]])
