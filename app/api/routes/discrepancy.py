"""The discrepancy workflow as a job: ``POST /discrepancy``."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, File, Form, Request, Response, UploadFile, status
from starlette.concurrency import run_in_threadpool

from app.api.deps import ReadAccess, RigsDep, SessionDep, WriteKeyDep
from app.schemas.common import ERROR_RESPONSES
from app.schemas.discrepancy import DiscrepancyAccepted, DiscrepancyForm
from app.schemas.jobs import QUEUE_FULL
from app.services.discrepancy import (
    MAX_SERIES_BYTES,
    plan_discrepancy,
    submit_discrepancy,
)

__all__ = ["router"]

#: Example: SIMULATED steady test points of the reference rig's pump, as a bench records them
#: (diagnostics.discrepancy.synthetic.synthesize_bench, seed 1: 3 speeds x 3 pressures x
#: 3 oil temperatures x 2 repeats, the bench's noise), in bar, rpm and L/min; against rig 1
#: the workflow answers "no effect" in ~0.02 s.  A measured cycle needs whole strokes (a few
#: thousand samples at 1 kHz), too long for an example.
_BENCH_EXAMPLE = (
    "p_in [bar],p_out [bar],n [rpm],theta [degC],q [L/min],replicate [-]\n"
    "0.0,10.017,1200.0,40.0,20.9438,0\n"
    "0.0,10.041,1200.0,40.0,20.8466,1\n"
    "0.0,10.017,1200.0,50.0,20.9455,0\n"
    "0.0,9.935,1200.0,50.0,20.899,1\n"
    "0.0,10.045,1200.0,60.0,20.8378,0\n"
    "0.0,10.022,1200.0,60.0,20.8844,1\n"
    "0.0,29.973,1200.0,40.0,20.7027,0\n"
    "0.0,30.029,1200.0,40.0,20.7136,1\n"
    "0.0,30.018,1200.0,50.0,20.6511,0\n"
    "0.0,30.015,1200.0,50.0,20.6449,1\n"
    "0.0,30.001,1200.0,60.0,20.7099,0\n"
    "0.0,30.027,1200.0,60.0,20.6768,1\n"
    "0.0,49.963,1200.0,40.0,20.5117,0\n"
    "0.0,49.992,1200.0,40.0,20.5378,1\n"
    "0.0,49.976,1200.0,50.0,20.4179,0\n"
    "0.0,50.03,1200.0,50.0,20.5127,1\n"
    "0.0,50.002,1200.0,60.0,20.561,0\n"
    "0.0,49.985,1200.0,60.0,20.4852,1\n"
    "0.0,9.961,1600.0,40.0,27.8596,0\n"
    "0.0,9.987,1600.0,40.0,27.9375,1\n"
    "0.0,10.0,1600.0,50.0,27.9126,0\n"
    "0.0,9.986,1600.0,50.0,27.9446,1\n"
    "0.0,10.065,1600.0,60.0,27.8828,0\n"
    "0.0,10.05,1600.0,60.0,27.8262,1\n"
    "0.0,29.864,1600.0,40.0,27.6945,0\n"
    "0.0,29.906,1600.0,40.0,27.6778,1\n"
    "0.0,29.991,1600.0,50.0,27.7386,0\n"
    "0.0,29.979,1600.0,50.0,27.7096,1\n"
    "0.0,30.011,1600.0,60.0,27.6188,0\n"
    "0.0,30.011,1600.0,60.0,27.6405,1\n"
    "0.0,50.106,1600.0,40.0,27.544,0\n"
    "0.0,49.944,1600.0,40.0,27.5339,1\n"
    "0.0,49.981,1600.0,50.0,27.4681,0\n"
    "0.0,50.102,1600.0,50.0,27.4999,1\n"
    "0.0,50.032,1600.0,60.0,27.5222,0\n"
    "0.0,50.033,1600.0,60.0,27.5233,1\n"
    "0.0,9.974,2000.0,40.0,34.9436,0\n"
    "0.0,9.918,2000.0,40.0,34.9128,1\n"
    "0.0,10.008,2000.0,50.0,34.8953,0\n"
    "0.0,10.005,2000.0,50.0,34.8871,1\n"
    "0.0,9.939,2000.0,60.0,34.9526,0\n"
    "0.0,9.966,2000.0,60.0,34.7879,1\n"
    "0.0,29.996,2000.0,40.0,34.6931,0\n"
    "0.0,29.953,2000.0,40.0,34.7016,1\n"
    "0.0,29.995,2000.0,50.0,34.629,0\n"
    "0.0,30.005,2000.0,50.0,34.7166,1\n"
    "0.0,30.002,2000.0,60.0,34.6676,0\n"
    "0.0,29.975,2000.0,60.0,34.7429,1\n"
    "0.0,50.03,2000.0,40.0,34.4937,0\n"
    "0.0,50.045,2000.0,40.0,34.5333,1\n"
    "0.0,50.016,2000.0,50.0,34.5607,0\n"
    "0.0,49.959,2000.0,50.0,34.5191,1\n"
    "0.0,50.037,2000.0,60.0,34.4564,0\n"
    "0.0,49.975,2000.0,60.0,34.4246,1\n"
)

router = APIRouter(tags=["discrepancy"], dependencies=[ReadAccess], responses=ERROR_RESPONSES)


@router.post("/discrepancy", status_code=status.HTTP_202_ACCEPTED,
             summary="Find what the rig model misses in measured data (a job)",
             responses={503: QUEUE_FULL})
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
        "A cycle needs whole strokes (a few thousand samples at 1 kHz; too few usable "
        "samples is a 422); the example is a steady bench table [-]",
        examples=[_BENCH_EXAMPLE])] = None,
) -> DiscrepancyAccepted:
    """Read the file (a bad column is a 422 naming it) or the stored records named by
    ``series_ids``, then start the workflow as a job.

    Unknown form fields are refused (422 naming the field).

    Follow it at ``/jobs/{job_id}``: the result is the report (named effects, evidence,
    fitted parameters with intervals, held-out gap before/after, whiteness, competing
    explanations) and ``new_rig_version``; ``/jobs/{job_id}?format=html`` gives the page.
    """
    content = None if file is None else await file.read(MAX_SERIES_BYTES + 1)
    plan = await run_in_threadpool(plan_discrepancy, session, rigs, form, content,
                                   file.filename if file is not None else None)
    job = submit_discrepancy(request.app.state.jobs, request.app.state.sessions, form, plan)
    response.headers["Location"] = f"/jobs/{job.id}"
    return DiscrepancyAccepted(job_id=job.id, status=job.status, records=plan.names,
                               channels=plan.channels)
