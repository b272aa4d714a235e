"""Measured time series of a rig: the upload form and what is read back (issue 12)."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from app.schemas.common import FiniteFloat, Page, PublicModel, Timestamp, UploadForm

__all__ = ["SeriesData", "SeriesImportForm", "SeriesList", "SeriesPublic"]


class SeriesImportForm(UploadForm):
    """Form fields sent with a time-series file (``POST /rigs/{rig_id}/series``).

    The file part is let through and other unknown fields refused
    (:class:`~app.schemas.common.UploadForm`).
    """

    name: str = Field(min_length=1, max_length=200, pattern=r"^[A-Za-z0-9_.:-]+$",
                      description="Name of the import (the file or campaign) [-]",
                      examples=["zema-cycles-1-100"])
    column_map: str | None = Field(
        default=None, max_length=20000,
        description="JSON object raw column → [channel, unit] for columns without a unit in "
        "their names, e.g. {\"PS1\": [\"P_pump\", \"bar\"]}; a column of record or stroke "
        "labels maps to [\"record\", \"-\"] or [\"phase\", \"-\"] [-]",
        examples=['{"PS1": ["P_pump", "bar"], "FS1": ["Q_meter_B", "L/min"], '
                  '"run": ["record", "-"]}'])
    sample_rate: FiniteFloat | None = Field(
        default=None, gt=0,
        description="Samples per second for a file without a time column [Hz]", examples=[1.0])


class SeriesPublic(PublicModel):
    """A stored record (without its samples; ``GET /series/{id}`` returns them)."""

    id: int = Field(description="Series identifier [-]", examples=[1])
    rig_id: int = Field(description="Rig the record was measured on [-]", examples=[1])
    name: str = Field(description="Name of the import [-]", examples=["zema-cycles-1-100"])
    record: str = Field(description="Record label within the import [-]", examples=["cycle-1"])
    sample_rate: float | None = Field(description="Uniform sampling rate, null when not "
                                      "uniform [Hz]", examples=[1.0])
    n_samples: int = Field(description="Number of samples [-]", examples=[60])
    measured: bool = Field(description="True for measured data, false for generated [-]",
                           examples=[True])
    units: dict[str, str] = Field(description="SI unit of every channel [-]",
                                  examples=[{"p_pump": "Pa", "q_work": "m^3/s"}])
    condition: dict[str, float] = Field(
        description="Constant operating condition: load [N], back_pressure [Pa], "
        "oil_temperature [°C], pump_speed [rad/s] — those known [SI]",
        examples=[{"oil_temperature": 45.2}])
    created_at: Timestamp


class SeriesData(SeriesPublic):
    """A stored record with its samples, in SI units."""

    t: list[float] = Field(description="Sample times [s]", examples=[[0.0, 1.0, 2.0]])
    channels: dict[str, list[float]] = Field(
        description="Channel → values, in the unit of ``units`` [SI]",
        examples=[{"p_pump": [1.91e7, 1.91e7, 1.47e7]}])

    phase: list[str] | None = Field(
        default=None, description="Phase label of every sample ('working', 'return'), null "
        "when the file had no phase column [-]", examples=[["working", "working", "return"]])

    @classmethod
    def of(cls, row: Any) -> SeriesData:
        """Build from a stored row."""
        base = SeriesPublic.model_validate(row).model_dump()
        return cls(**base, t=row.data["t"], channels=row.data["channels"],
                   phase=row.data.get("phase"))


class SeriesList(Page[SeriesPublic]):
    """A page of stored records."""
