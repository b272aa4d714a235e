"""Re-diagnosis of a rig's stored records as a job: ``POST /rigs/{rig_id}/rediagnose``."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request, Response, status

from app.api.deps import ExecutorsDep, ReadAccess, RigsDep, SessionDep, WriteKeyDep
from app.api.routes.rigs import RigId
from app.schemas.common import ERROR_RESPONSES
from app.schemas.jobs import QUEUE_FULL
from app.schemas.rediagnose import RediagnoseAccepted, RediagnoseRequest
from app.services.executors import SweepExecutors
from app.services.jobs import JobRunner, Progress
from app.services.rediagnosis import RediagnosisPlan, plan_rediagnosis, run_rediagnosis

__all__ = ["router"]

router = APIRouter(tags=["rigs"], dependencies=[ReadAccess], responses=ERROR_RESPONSES)


def _job(plan: RediagnosisPlan, request: Request, executors: SweepExecutors) -> Any:
    sessions = request.app.state.sessions

    def rediagnose(_params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        return run_rediagnosis(plan, sessions, executors.get() if plan.stale else None,
                               progress, executors.waiting(progress))

    return rediagnose


@router.post("/rigs/{rig_id}/rediagnose", status_code=status.HTTP_202_ACCEPTED,
             summary="Diagnose stored records again against the rig's latest version (a job)",
             responses={503: QUEUE_FULL})
def rediagnose(rig_id: RigId, request: Request, session: SessionDep, rigs: RigsDep,
               executors: ExecutorsDep, _key: WriteKeyDep, response: Response,
               body: RediagnoseRequest | None = None) -> RediagnoseAccepted:
    """Diagnose again, against the latest version, the records of every current diagnosis
    made with an older version (default: the versions whose parameters differ, which the
    trends leave out; a joint visit jointly).  Each new diagnosis is kept with the same
    records and the old one is marked ``superseded_by`` it: listings and trends read the
    new ones, ``GET /diagnoses/{id}`` still reads the old.  Follow it at ``/jobs/{job_id}``;
    the result lists each replaced diagnosis (``before`` → ``after``) and the groups the
    latest version could not take (their old diagnosis stays current).  Stored chunk by
    chunk: a cancelled job keeps what it stored, and running again takes the rest."""
    plan = plan_rediagnosis(session, rigs, rig_id,
                            None if body is None else body.versions)
    runner: JobRunner = request.app.state.jobs
    params = {"rig_id": rig_id, "versions": list(plan.versions)}
    job = runner.submit("rediagnose", params, _job(plan, request, executors))
    response.headers["Location"] = f"/jobs/{job.id}"
    return RediagnoseAccepted(job_id=job.id, status=job.status, rig_id=rig_id,
                              rig_version=plan.resolved.version, versions=list(plan.versions),
                              n_diagnoses=len(plan.stale), remaining=plan.remaining,
                              executor=executors.kind)
