"""Jobs: status and progress of long work (sweeps, maps, discrepancy runs)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Path, Query, Response
from fastapi.responses import HTMLResponse

from app.api.deps import PageDep, ReadAccess, SessionDep, WriteKeyDep
from app.api.rendered import rendered
from app.schemas.common import ERROR_RESPONSES
from app.schemas.jobs import JobList, JobPublic, JobStatus, job_summary
from app.services import jobs as service
from sim.errors import ConflictError, InputError

__all__ = ["router"]

router = APIRouter(prefix="/jobs", tags=["jobs"], dependencies=[ReadAccess],
                   responses=ERROR_RESPONSES)


@router.get("", summary="List jobs", response_model=JobList)
def list_jobs(
    session: SessionDep,
    page: PageDep,
    status: Annotated[JobStatus | None, Query(description="Only jobs in this state [-]",
                                              examples=["running"])] = None,
    kind: Annotated[str | None, Query(max_length=64, description="Only jobs of this kind [-]",
                                      examples=["sweep"])] = None,
    results: Annotated[bool, Query(
        description="Give each job's result (a sweep's can be megabytes); by default null, "
        "read from GET /jobs/{id} [-]", examples=[False])] = False,
) -> Response:
    """Return a page of jobs, newest first, without their results unless asked."""
    rows, total = service.list_jobs(session, limit=page.limit, offset=page.offset,
                                    status=status, kind=kind, results=results)
    items = [JobPublic.model_validate(j) if results else job_summary(j) for j in rows]
    return rendered(JobList(items=items, total=total, limit=page.limit, offset=page.offset,
                            results=results))


@router.get("/{job_id}", summary="Get a job's status, progress and outcome",
            response_model=JobPublic,
            responses={200: {"content": {"text/html": {}},
                             "description": "The job as JSON, or with format=html the page "
                             "of a job whose result has one (discrepancy reports)"}})
def get_job(
    job_id: Annotated[str, Path(max_length=36, description="Job identifier (UUID) [-]",
                                examples=["1b4e28ba-2fa1-11d2-883f-0016d3cca427"])],
    session: SessionDep,
    format: Annotated[Literal["json", "html"], Query(
        description="'html': the self-contained report page of a finished job that has one "
        "[-]", examples=["json"])] = "json",
) -> Any:
    """Return the job; poll until ``status`` is ``succeeded`` or ``failed``."""
    job = service.get_job(session, job_id)
    if format == "html":
        page = (job.result or {}).get("html") if job.status == "succeeded" else None
        if job.status in ("queued", "running") and job.kind == "discrepancy":
            # a valid request, early: not a 422 on the format (a discrepancy pass)
            raise ConflictError(f"job {job_id} is {job.status}: its report is there when it "
                                "has succeeded (poll GET /jobs/{id})", field="format")
        if not isinstance(page, str):
            raise InputError(f"job {job_id} has no HTML report (status {job.status!r}, kind "
                             f"{job.kind!r})", field="format")
        return HTMLResponse(page)
    return rendered(JobPublic.model_validate(job))


@router.post("/{job_id}/cancel", summary="Cancel a job", response_model=JobPublic,
             status_code=202)
def cancel_job(
    job_id: Annotated[str, Path(max_length=36, description="Job identifier (UUID) [-]",
                                examples=["1b4e28ba-2fa1-11d2-883f-0016d3cca427"])],
    session: SessionDep,
    _key: WriteKeyDep,
) -> Any:
    """Cancel a job: a queued one at once (``status`` ``cancelled``), a running one at its
    next progress report (``cancel_requested_at`` set now; poll ``GET /jobs/{id}`` until
    ``status`` is ``cancelled``, or ``succeeded`` if it finished first).  Asking again, or
    of a cancelled job, changes nothing; a job that has succeeded or failed is answered
    409."""
    return JobPublic.model_validate(service.cancel_job(session, job_id))
