"""Sweeps over fault scenarios as jobs: ``POST /scenarios``."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request, Response, status

from app.api.deps import ExecutorsDep, ReadAccess, RigsDep, SessionDep, WriteKeyDep
from app.schemas.common import ERROR_RESPONSES
from app.schemas.jobs import QUEUE_FULL
from app.schemas.sweeps import SweepAccepted, SweepRequest
from app.services.executors import SweepExecutors
from app.services.jobs import JobRunner, Progress
from app.services.sweeps import SweepPlan, plan_sweep, run_sweep

__all__ = ["router"]

router = APIRouter(tags=["scenarios"], dependencies=[ReadAccess], responses=ERROR_RESPONSES)


def _job(plan: SweepPlan, executors: SweepExecutors) -> Any:
    def sweep(_params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        return run_sweep(plan, executors.get(), progress, executors.waiting(progress))

    return sweep


@router.post("/scenarios", status_code=status.HTTP_202_ACCEPTED,
             summary="Start a sweep over fault scenarios (a job)",
             responses={503: QUEUE_FULL})
def start_sweep(body: SweepRequest, request: Request, session: SessionDep, rigs: RigsDep,
                executors: ExecutorsDep, _key: WriteKeyDep, response: Response) -> SweepAccepted:
    """Check the sweep, lay out its points and start it as a job.

    Follow it at ``/jobs/{job_id}``: ``progress`` grows as points come back; the result has
    ``columns`` (fault, swept factors, summary keys with units) and ``rows``.
    """
    plan = plan_sweep(session, rigs, body, request.app.state.settings.sweep_points)
    runner: JobRunner = request.app.state.jobs
    job = runner.submit("sweep", body.model_dump(mode="json"), _job(plan, executors))
    response.headers["Location"] = f"/jobs/{job.id}"
    return SweepAccepted(job_id=job.id, status=job.status, n_points=len(plan.points),
                         executor=executors.kind)
