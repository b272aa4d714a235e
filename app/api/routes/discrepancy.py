"""The discrepancy workflow as a job: ``POST /discrepancy``."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, File, Form, Request, Response, UploadFile, status
from starlette.concurrency import run_in_threadpool

from app.api.deps import ReadAccess, RigsDep, SessionDep, WriteKeyDep
from app.schemas.common import ERROR_RESPONSES
from app.schemas.discrepancy import DiscrepancyAccepted, DiscrepancyForm
from app.services.discrepancy import (
    MAX_SERIES_BYTES,
    plan_discrepancy,
    submit_discrepancy,
)

__all__ = ["router"]

router = APIRouter(tags=["discrepancy"], dependencies=[ReadAccess], responses=ERROR_RESPONSES)


@router.post("/discrepancy", status_code=status.HTTP_202_ACCEPTED,
             summary="Find what the rig model misses in measured data (a job)")
async def start_discrepancy(
    form: Annotated[DiscrepancyForm, Form()],
    request: Request, session: SessionDep, rigs: RigsDep, _key: WriteKeyDep,
    response: Response,
    file: Annotated[UploadFile | None, File(
        description="Measured time series in the /simulate export format (CSV or Parquet, "
        "units in the column names, 'phase' and optional 'record' columns, each record's "
        "load and oil temperature as constant columns or the export's '# condition' header), "
        "or steady pump test points in the pump-bench CSV format (p_in, p_out, n, theta, q "
        "with units, optional replicate); leave out when series_ids names stored records. "
        "The example shows the format only: the workflow needs whole strokes (a few "
        "thousand samples at 1 kHz), and too few usable samples is a 422 [-]",
        examples=["record,t [s],phase,P1 [Pa],P2 [Pa],v [m/s],load [N],"
                  "oil_temperature [degC]\n"
                  "load-2100,0.100,working,1.20e6,1.0e5,0.210,2100,40\n"
                  "load-2100,0.101,working,1.21e6,1.0e5,0.211,2100,40\n"
                  "load-2100,0.102,working,1.20e6,1.0e5,0.210,2100,40\n"])] = None,
) -> DiscrepancyAccepted:
    """Read the file (a bad column is a 422 naming it) or the stored records named by
    ``series_ids``, then start the workflow as a job.

    Unknown form fields are refused (422 naming the field).

    Follow it at ``/jobs/{job_id}``: the result is the report (named effects, evidence,
    fitted parameters with intervals, held-out gap before/after, whiteness, competing
    explanations) and ``new_rig_version``; ``/jobs/{job_id}?format=html`` gives the page.
    """
    content = None if file is None else await file.read(MAX_SERIES_BYTES + 1)
    plan = await run_in_threadpool(plan_discrepancy, session, rigs, form, content)
    job = submit_discrepancy(request.app.state.jobs, request.app.state.sessions, form, plan)
    response.headers["Location"] = f"/jobs/{job.id}"
    return DiscrepancyAccepted(job_id=job.id, status=job.status, records=plan.names,
                               channels=plan.channels)
