"""Jobs: status and progress of long work (sweeps, maps, discrepancy runs)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Query

from app.api.deps import PageDep, ReadAccess, SessionDep
from app.schemas.common import ERROR_RESPONSES
from app.schemas.jobs import JobList, JobPublic, JobStatus
from app.services import jobs as service

__all__ = ["router"]

router = APIRouter(prefix="/jobs", tags=["jobs"], dependencies=[ReadAccess],
                   responses=ERROR_RESPONSES)


@router.get("", summary="List jobs")
def list_jobs(
    session: SessionDep,
    page: PageDep,
    status: Annotated[JobStatus | None, Query(description="Only jobs in this state [-]",
                                              examples=["running"])] = None,
    kind: Annotated[str | None, Query(max_length=64, description="Only jobs of this kind [-]",
                                      examples=["sweep"])] = None,
) -> JobList:
    """Return a page of jobs, newest first."""
    rows, total = service.list_jobs(session, limit=page.limit, offset=page.offset,
                                    status=status, kind=kind)
    return JobList(items=[JobPublic.model_validate(j) for j in rows], total=total,
                   limit=page.limit, offset=page.offset)


@router.get("/{job_id}", summary="Get a job's status, progress and outcome")
def get_job(
    job_id: Annotated[str, Path(max_length=36, description="Job identifier (UUID) [-]",
                                examples=["1b4e28ba-2fa1-11d2-883f-0016d3cca427"])],
    session: SessionDep,
) -> JobPublic:
    """Return the job; poll until ``status`` is ``succeeded`` or ``failed``."""
    return JobPublic.model_validate(service.get_job(session, job_id))
