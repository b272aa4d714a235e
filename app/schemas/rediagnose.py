"""Request and answer of ``POST /rigs/{rig_id}/rediagnose``."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, Field

from app.schemas.common import MAX_ID, RequestModel

__all__ = ["RediagnoseAccepted", "RediagnoseRequest"]


class RediagnoseRequest(RequestModel):
    """Which stored diagnoses to do again against the rig's latest version."""

    versions: list[Annotated[int, Field(ge=1, le=MAX_ID)]] | None = Field(
        default=None, min_length=1, max_length=1000,
        description="The older versions whose current diagnoses are done again; default "
        "(null): every older version whose parameters or fluid differ from the latest's — "
        "those the trends leave out [-]", examples=[[1]])


class RediagnoseAccepted(BaseModel):
    """A re-diagnosis accepted as a job; follow it at ``/jobs/{job_id}``."""

    job_id: str = Field(description="Job identifier (UUID) [-]",
                        examples=["1b4e28ba-2fa1-11d2-883f-0016d3cca427"])
    status: str = Field(description="Job state at acceptance [-]", examples=["queued"])
    rig_id: int = Field(description="Rig identifier [-]", examples=[1])
    rig_version: int = Field(description="The latest version, the records are diagnosed "
                             "against [-]", examples=[2])
    versions: list[int] = Field(description="The versions whose diagnoses are done again "
                                "(empty: nothing to do) [-]", examples=[[1]])
    n_diagnoses: int = Field(ge=0, description="Diagnoses to do again in this run [-]",
                             examples=[39])
    remaining: int = Field(ge=0, description="Diagnoses of those versions beyond this run's "
                           "50,000 (the oldest go first): run again for them [-]",
                           examples=[0])
    executor: str = Field(description="Where they run: 'processes' or 'dask' [-]",
                          examples=["processes"])
