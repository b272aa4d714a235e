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

__all__ = ["Health", "Readiness", "router"]

#: how long /ready waits for the database [s]
READY_TIMEOUT_S = 5.0

router = APIRouter(tags=["operations"])


class Health(BaseModel):
    """The process is up."""

    status: Literal["ok"] = Field(description="Always 'ok' when the process answers [-]",
                                  examples=["ok"])
    version: str = Field(description="hydrodiag version [-]", examples=["0.1.0"])


class Readiness(BaseModel):
    """The store is reachable and migrated, and the stored rigs are loaded."""

    status: Literal["ready"] = Field(description="'ready' when requests can be served [-]",
                                     examples=["ready"])
    database: str = Field(description="Database backend [-]", examples=["sqlite"])
    revision: str = Field(description="Schema revision of the store [-]", examples=["0001"])


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
    operator pass)."""
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
    return Readiness(status="ready", database=engine.dialect.name, revision=revision)


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
    return Response(content=data, media_type=CONTENT_TYPE_LATEST)
