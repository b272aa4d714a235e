"""Operations: liveness, readiness, Prometheus metrics; all three open (no API key).

``/health`` is an ``async`` route that touches nothing: it runs on the event loop, so it
answers while every worker thread is busy with diagnoses (it never queues behind them).
"""

from __future__ import annotations

import asyncio
from typing import Literal, get_args

from fastapi import APIRouter, Request, Response
from prometheus_client import CONTENT_TYPE_LATEST
from pydantic import BaseModel, Field
from sqlalchemy import func, select
from sqlalchemy.exc import InterfaceError, OperationalError, SQLAlchemyError

from app import __version__
from app.db import migrate
from app.db.engine import ping
from app.db.models import Job
from app.errors import ServiceUnavailableError, WarmingUpError
from app.metrics import exposition
from app.schemas.common import error_doc
from app.schemas.jobs import JobStatus
from app.services.executors import Connection, SweepExecutors

__all__ = ["Health", "Readiness", "SweepsState", "router", "sweeps_state"]

#: how long /ready waits for the database [s]
READY_TIMEOUT_S = 5.0
#: how long /ready and /metrics wait for the Dask scheduler's count of workers [s]
EXECUTOR_TIMEOUT_S = 2.0

router = APIRouter(tags=["operations"])


class Health(BaseModel):
    """The process is up."""

    status: Literal["ok"] = Field(description="Always 'ok' when the process answers [-]",
                                  examples=["ok"])
    version: str = Field(description="hydrodiag version [-]", examples=["0.1.0"])


class SweepsState(BaseModel):
    """Where sweeps, discrepancy jobs and re-diagnoses run (informative: it does not
    decide readiness, as diagnoses and simulations run in the service itself)."""

    kind: Literal["processes", "dask"] = Field(
        description="'processes' (a local pool) or 'dask' (HYDRODIAG_DASK_SCHEDULER) [-]",
        examples=["processes"])
    scheduler: str | None = Field(
        description="The Dask scheduler's address; null for the local pool [-]",
        examples=[None])
    connection: Connection = Field(
        description="'local'; for Dask 'idle' (not connected yet: the first sweep "
                    "connects), 'connected', 'reconnecting', 'closed' (the next sweep "
                    "connects again) or 'not answering' (no answer within "
                    f"{EXECUTOR_TIMEOUT_S:g} s) [-]", examples=["local"])
    workers: int | None = Field(
        description="Processes of the local pool, or the Dask cluster's workers when "
                    "connected; null when not known [-]", examples=[2])
    threads: int | None = Field(
        description="Tasks run at once (processes, or the workers' threads); null when "
                    "not known [-]", examples=[2])


class Readiness(BaseModel):
    """The store is reachable and migrated, and the stored rigs are loaded."""

    status: Literal["ready"] = Field(description="'ready' when requests can be served [-]",
                                     examples=["ready"])
    database: str = Field(description="Database backend [-]", examples=["sqlite"])
    revision: str = Field(description="Schema revision of the store [-]", examples=["0001"])
    sweeps: SweepsState = Field(
        description="Where sweeps and re-diagnoses run [see its fields]",
        examples=[{"kind": "processes", "scheduler": None, "connection": "local",
                   "workers": 2, "threads": 2}])


def sweeps_state(executors: SweepExecutors) -> SweepsState:
    """The executor's state within :data:`EXECUTOR_TIMEOUT_S` (blocks up to that long)."""
    st = executors.state_within(EXECUTOR_TIMEOUT_S)
    return SweepsState(kind=st.kind, scheduler=st.scheduler, connection=st.connection,
                       workers=st.workers, threads=st.threads)


@router.get("/health", summary="Liveness: the process answers")
async def health() -> Health:
    """Answer as long as the process runs; touches nothing else (container HEALTHCHECK)."""
    return Health(status="ok", version=__version__)


@router.get(
    "/ready",
    summary="Readiness: the database is reachable and migrated, the rigs are loaded",
    responses={503: error_doc("Database unreachable or not migrated, or rigs still loading")},
)
async def ready(request: Request) -> Readiness:
    """Query the database, compare its schema revision with the package's newest, and
    check that the start-up warming of the stored rigs has finished.  A database that
    does not answer within :data:`READY_TIMEOUT_S` is unreachable: a frozen PostgreSQL
    (accepting connections, answering nothing) held /ready for 100 s and more (an
    operator pass).  The sweeps' executor is reported (a Dask scheduler's address and
    workers: nothing named it, a Dask pass), not required: a scheduler away makes a
    sweep a 503 naming it, while diagnoses go on."""
    engine = request.app.state.engine

    def check() -> str | None:
        ping(engine)
        return migrate.current_revision(engine)

    try:
        revision = await asyncio.wait_for(asyncio.to_thread(check), READY_TIMEOUT_S)
    except SQLAlchemyError as exc:
        raise ServiceUnavailableError(f"database unreachable: {type(exc).__name__}") from exc
    except TimeoutError as exc:
        raise ServiceUnavailableError(f"the database did not answer within "
                                      f"{READY_TIMEOUT_S:g} s") from exc
    head = migrate.head_revision()
    if revision != head:
        raise ServiceUnavailableError(f"database at revision {revision}, service needs {head}")
    warmup = getattr(request.app.state, "warmup", None)
    if warmup is None or not warmup.done:
        raise WarmingUpError("the stored rigs are still loading")
    sweeps = await asyncio.to_thread(sweeps_state, request.app.state.sweep_executors)
    return Readiness(status="ready", database=engine.dialect.name, revision=revision,
                     sweeps=sweeps)


@router.get(
    "/metrics",
    summary="Prometheus metrics: requests and latency per route",
    response_class=Response,
    responses={200: {"content": {CONTENT_TYPE_LATEST: {}}, "description": "Prometheus text"}},
)
def metrics(request: Request) -> Response:
    """Expose the counters in the Prometheus text format (every server worker's, summed),
    and the store's jobs by status (``hydrodiag_jobs``; read from the store, which every
    worker and instance shares: stuck ``queued`` jobs showed nowhere, an operator pass)."""
    data = exposition(request.app.state.metrics.registry)
    try:
        with request.app.state.sessions() as session:
            counts = {str(status): int(n) for status, n in session.execute(
                select(Job.status, func.count()).group_by(Job.status))}
    except (OperationalError, InterfaceError):   # the store away: the counters still
        counts = None
    if counts is not None:
        lines = ["# HELP hydrodiag_jobs Jobs in the store by status",
                 "# TYPE hydrodiag_jobs gauge"]
        lines += [f'hydrodiag_jobs{{status="{status}"}} {counts.get(status, 0)}'
                  for status in get_args(JobStatus)]
        data += ("\n".join(lines) + "\n").encode()
    data += _executor_lines(sweeps_state(request.app.state.sweep_executors))
    return Response(content=data, media_type=CONTENT_TYPE_LATEST)


def _label(value: str) -> str:
    """A Prometheus label value, escaped."""
    return value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")


def _executor_lines(st: SweepsState) -> bytes:
    """The sweeps' executor as an info gauge (its kind, scheduler and connection as
    labels, value 1) and its threads when known: this server worker's executor."""
    labels = (f'kind="{st.kind}",scheduler="{_label(st.scheduler or "")}",'
              f'connection="{st.connection}"')
    lines = ["# HELP hydrodiag_executor Where sweeps and re-diagnoses run (this server "
             "worker's executor; connection: local, idle, connected, reconnecting, "
             "closed, not answering)",
             "# TYPE hydrodiag_executor gauge", f"hydrodiag_executor{{{labels}}} 1"]
    if st.threads is not None:
        lines += ["# HELP hydrodiag_executor_threads Tasks the sweeps' executor runs at "
                  "once (local processes or Dask worker threads)",
                  "# TYPE hydrodiag_executor_threads gauge",
                  f'hydrodiag_executor_threads{{kind="{st.kind}"}} {st.threads}']
    return ("\n".join(lines) + "\n").encode()
