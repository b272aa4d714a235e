"""The pump's leak per stored cycle of a rig without a cylinder: ``POST /rigs/{rig_id}/pump-leak``."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated

from pydantic import BaseModel, Field

from app.schemas.common import MAX_ID, FiniteFloat, RequestModel
from diagnostics.real.relaxation import MAX_RELAXATION, ZEMA_RELAXATION

__all__ = ["MAX_CYCLES", "CycleLeakPublic", "LeakShiftPublic", "PumpLeakRequest",
           "PumpLeakResponse"]

SeriesIdIn = Annotated[int, Field(ge=1, le=MAX_ID)]

#: most cycles one request reads (the ZeMA campaign is 2,205; ~0.3 ms of CPU a cycle)
MAX_CYCLES = 5000


class PumpLeakRequest(RequestModel):
    """Which stored cycles to read, against what, and the estimate's settings."""

    series_ids: list[SeriesIdIn] | None = Field(
        default=None, min_length=2, max_length=MAX_CYCLES,
        description="Stored cycles of the rig (POST /rigs/{rig_id}/series, one record a "
        "cycle); when null, the rig's stored cycles but the baseline's: the latest `last` "
        f"of them, every one up to {MAX_CYCLES} without it [-]",
        examples=[None])
    last: int | None = Field(
        default=None, ge=2, le=MAX_CYCLES,
        description="With series_ids null, read the rig's latest this many stored cycles "
        "(by clock time, then order of import; those without a clock time count as the "
        f"oldest); null reads every one, the latest {MAX_CYCLES} when there are more, "
        "said in the answer's notes [-]", examples=[None])
    baseline_series_ids: list[SeriesIdIn] | None = Field(
        default=None, min_length=10, max_length=MAX_CYCLES,
        description="Stored cycles of the rig known healthy (after commissioning or an "
        "overhaul) to read the others against; without them the batch's lower group is its "
        "healthy reference, and a batch of one class of cycles is refused [-]",
        examples=[None])
    shunt: FiniteFloat | None = Field(
        default=None, ge=0.0, le=1.0e-9,
        description="λ of the laminar shunt, as given (fitted once on a campaign that spans "
        "the oil temperatures: a leak size that does not depend on the batch); fitted on "
        "the batch when null [m³]", examples=[None])
    relaxation: FiniteFloat = Field(
        default=ZEMA_RELAXATION, ge=0.0, le=MAX_RELAXATION,
        description="Relaxation time of the accumulator gas after a pressure step: each "
        "plateau's flow is its settled value q∞ of q∞ + c·e^(−t/τ); 0 takes plateau means "
        "(the default is the ZeMA rig's, found without labels) [s]",
        examples=[ZEMA_RELAXATION])
    window: FiniteFloat = Field(
        default=1.0, gt=0.0, le=20.0,
        description="Half-width of the oil-temperature neighbourhood of a cycle's healthy "
        "reference [°C]", examples=[1.0])
    min_segment: int = Field(
        default=10, ge=2, le=MAX_CYCLES,
        description="Fewest cycles on each side of a shift of the leak size [-]",
        examples=[10])


class CycleLeakPublic(BaseModel):
    """One cycle's leak."""

    series_id: int | None = Field(description="Stored series of the cycle [-]",
                                  examples=[12], le=MAX_ID)
    name: str = Field(description="The record's name [-]", examples=["cycle-211"])
    measured_at: datetime | None = Field(
        description="Clock time of the cycle's first sample (UTC; null when the import "
        "stated none) [-]", examples=[None])
    oil_temperature: float = Field(description="Oil temperature on its working plateaus [°C]",
                                   examples=[45.2])
    pressure: float = Field(description="Pump pressure on its working plateaus [Pa]",
                            examples=[1.55e7])
    flow: float = Field(description="Settled working flow on its plateaus [m³/s]",
                        examples=[1.265e-4])
    deficit: float = Field(description="Healthy reference flow at its oil temperature and "
                           "pressure less its flow [m³/s]", examples=[4.9e-6])
    size: float | None = Field(
        description="Orifice leak size K of Δq = K·√Δp + λ·Δp/μ; null where a baseline has "
        "no cycle within the temperature window (not judged) [m³/(s·Pa^½)]",
        examples=[1.2e-9])
    leak_flow: float | None = Field(
        description="K·√Δp, the orifice's leak at the cycle's plateau pressure [m³/s]",
        examples=[4.7e-6])
    leaking: bool = Field(description="Deficit above the leak threshold (false where not "
                          "judged) [-]", examples=[True])


class LeakShiftPublic(BaseModel):
    """A step of the leak size between two segments of cycles."""

    index: int = Field(description="Position in `cycles` of the first cycle after the step "
                       "[-]", examples=[210])
    series_id: int | None = Field(description="Its stored series [-]", examples=[221])
    name: str = Field(description="Its record's name [-]", examples=["cycle-211"])
    measured_at: datetime | None = Field(description="Its clock time (UTC) [-]",
                                         examples=[None])
    size_before: float = Field(description="Median K of the segment before [m³/(s·Pa^½)]",
                               examples=[0.0])
    size_after: float = Field(description="Median K of the segment after [m³/(s·Pa^½)]",
                              examples=[1.73e-9])


class PumpLeakResponse(BaseModel):
    """The leak of every cycle, the values found without labels, and the shifts."""

    rig_id: int = Field(description="Rig [-]", examples=[2])
    rig_version: int = Field(description="Rig version whose oil (μ(θ)) was used [-]",
                             examples=[1])
    reference: str = Field(description="'batch' (the leak beyond the batch's lower group) or "
                           "'baseline' (against cycles known healthy) [-]",
                           examples=["batch"])
    leaking: int = Field(description="Cycles above the leak threshold [-]", examples=[180])
    threshold: float = Field(description="Deficit above which a cycle leaks [m³/s]",
                             examples=[1.75e-6])
    slope: float = Field(description="Healthy dq/dp on the plateaus [m³/(s·Pa)]",
                         examples=[-4.6e-13])
    shunt: float = Field(description="λ of the laminar shunt (its flow λ·Δp/μ) [m³]",
                         examples=[2.2e-15])
    separation: float | None = Field(
        description="Separation of the batch's leak split (null against a baseline) "
        "[robust σ]", examples=[12.5])
    relaxation: float = Field(description="The accumulator gas's relaxation time used [s]",
                              examples=[3.5])
    fitted_on: int = Field(description="Cycles the slope and the shunt were fitted on [-]",
                           examples=[401])
    cycles: list[CycleLeakPublic] = Field(
        description="Every cycle, in time order [-]", examples=[[{
            "series_id": 221, "name": "cycle-211", "measured_at": None,
            "oil_temperature": 45.2, "pressure": 1.55e7, "flow": 1.265e-4,
            "deficit": 4.9e-6, "size": 1.2e-9, "leak_flow": 4.7e-6, "leaking": True}]])
    shifts: list[LeakShiftPublic] = Field(
        description="Steps of the leak size of practical size, in time order [-]",
        examples=[[{"index": 210, "series_id": 221, "name": "cycle-211", "measured_at": None,
                    "size_before": 0.0, "size_after": 1.73e-9}]])
    notes: list[str] = Field(description="What the estimate chose or could not do [-]",
                             examples=[["not every cycle has a clock time: the cycles are "
                                        "taken in the order given"]])
