"""The FastAPI application: :func:`create_app` wires settings, store, jobs and routes.

``uvicorn app.main:create_service_app --factory`` serves it as ``hydrodiag serve`` does:
it migrates the store and preloads the reference rig at start-up (a no-op on a store that
is up to date), minus the first-start API key (``hydrodiag keys create``); ``serve`` uses
that factory itself for several workers.  Every process warms the stored rigs at start-up
(:class:`app.services.warmup.Warmup`) and reports ready only once they are loaded.
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import logging
import multiprocessing
from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI
from fastapi.dependencies.models import Dependant
from fastapi.openapi.utils import get_openapi
from fastapi.routing import APIRoute, iter_route_contexts
from fastapi_offline import FastAPIOffline

from app import __version__
from app.api.deps import OPEN_READ_ACCESS, SCOPE_OF
from app.api.router import api_router
from app.console import router as console_router
from app.db.engine import make_engine, make_session_factory
from app.errors import CatchAllMiddleware, install_error_handlers
from app.idempotency import HEADER as IDEMPOTENCY_HEADER
from app.idempotency import IDEMPOTENT_METHODS, KEEP_HOURS, IdempotencyMiddleware
from app.lifeline import exit_with_parent
from app.limits import BodyLimitMiddleware
from app.logs import RequestLogMiddleware, configure_logging
from app.metrics import HttpMetrics, MetricsMiddleware
from app.ratelimit import FAILED_KEYS_PER_MINUTE, KeyRateLimiter
from app.security import Scope
from app.services.bootstrap import bootstrap_lock, ensure_reference_data, upgrade_database
from app.services.clearance import ClearanceEstimator
from app.services.diagnosis_pool import DiagnosisPool
from app.services.executors import SweepExecutors
from app.services.group_commit import GroupCommitter
from app.services.jobs import JobRunner, fail_interrupted_jobs
from app.services.rig_cache import ResolvedRig, RigCache
from app.services.warmup import Warmup
from app.settings import Settings

__all__ = ["DOCS_STATIC", "create_app", "create_service_app"]

#: where the documentation pages' script and style files are served (no key needed)
DOCS_STATIC = "/docs-static"

logger = logging.getLogger("hydrodiag.app")

_DESCRIPTION = """\
Fault diagnosis of hydraulic rigs from bond-graph models.

Every quantity is in SI units, named in brackets in each field's description.  Errors have
one body: `{"error": {"type": ..., "message": ..., "field": ..., "request_id": ...}}`; every
response carries `X-Request-ID` (the client's, when well formed: 1 to 64 letters, digits or
`-._:`; else a new one), which the service log names too; request bodies over
the size limit are answered 413, unknown fields in a body 422.

**Access.** Every operation needs an API key in the `X-API-Key` header except `/health`,
`/ready`, `/metrics` and the documentation (`/docs`, `/redoc`, `/openapi.json`).  A
service started with `HYDRODIAG_OPEN_READS=true` also answers the operations marked
`x-hydrodiag-access: open-reads` without a key (the reads, `/simulate`, and `/diagnose`
with `"store": false`); anything that stores or changes data always needs the key.

**Scopes.** Each key is `read`, `write` or `admin` (`hydrodiag keys create --scope`); each
includes the ones before it.  `x-hydrodiag-scope` on each operation names the scope it
needs: `read` for the reads, `/simulate` and `/diagnose` (`write` with `"store": true`,
stated as `x-hydrodiag-scope-store`), `write` for whatever stores or changes data, `admin`
for deletions.  A valid key below the needed scope is answered 403 (`ScopeError`).

**Retries.** A write may carry `Idempotency-Key` (1-255 visible ASCII characters): its first
success is kept 24 h, and the same request sent again with the same key gets that answer
(`Idempotent-Replayed: true`) without being run or stored twice; sent while the first still
runs, 409 with `Retry-After`; the key on another request, 422.  Without it, a resent write is
a new one.  A database that does not answer gives 503 with `Retry-After`, nothing stored.
"""

#: Value of ``x-hydrodiag-access`` on each operation, by how it is guarded.
ACCESS_OPEN, ACCESS_OPEN_READS, ACCESS_KEY = "open", "open-reads", "key"


def _calls(dependant: Dependant) -> set[Any]:
    found = {dependant.call}
    for child in dependant.dependencies:
        found |= _calls(child)
    return found


def _access_of(route: APIRoute) -> tuple[str, Scope | None]:
    """How ``route`` is guarded, and the scope of key it needs (``None``: no key)."""
    calls = _calls(route.dependant)
    scopes = [SCOPE_OF[call] for call in calls if call in SCOPE_OF]
    scope = max(scopes, key=lambda s: s.rank) if scopes else None
    if any(call in SCOPE_OF and call not in OPEN_READ_ACCESS for call in calls):
        return ACCESS_KEY, scope
    if calls & OPEN_READ_ACCESS:
        return ACCESS_OPEN_READS, scope
    return ACCESS_OPEN, None


#: the ``Idempotency-Key`` header of every keyed write, as an OpenAPI parameter
IDEMPOTENCY_PARAMETER: dict[str, Any] = {
    "name": IDEMPOTENCY_HEADER, "in": "header", "required": False,
    "description": "A key of 1-255 visible ASCII characters that makes a retry of this "
                   f"write safe: the same key with the same request within {KEEP_HOURS} h "
                   "replays the first answer (Idempotent-Replayed: true) instead of doing it "
                   "again [-]",
    "schema": {"type": "string", "minLength": 1, "maxLength": 255},
    "examples": {"a retry key": {"value": "7d2c41e0-rig-1-visit-2026-11-30"}},
}


def _documented_openapi(app: FastAPI, open_reads: bool) -> dict[str, Any]:
    """The OpenAPI document with each operation's access stated under this setting.

    ``x-hydrodiag-access`` is ``open``, ``open-reads`` or ``key``; ``x-hydrodiag-scope``
    (on every operation but the open ones) is the key scope it needs, ``read``, ``write``
    or ``admin``; ``security`` lists the
    API key on every operation that needs it under the running settings, and for the
    ``open-reads`` ones when reads are open offers the empty requirement too (key
    optional).
    """
    if app.openapi_schema is None:
        schema = get_openapi(title=app.title, version=app.version,
                             description=app.description, routes=app.routes)
        for context in iter_route_contexts(app.routes):
            route = context.route
            if not isinstance(route, APIRoute) or not route.include_in_schema:
                continue
            access, scope = _access_of(route)
            for method in context.methods or ():
                operation = schema["paths"].get(context.path_format, {}).get(method.lower())
                if operation is None:
                    continue
                operation["x-hydrodiag-access"] = access
                if scope is not None:
                    operation["x-hydrodiag-scope"] = scope.value
                if access == ACCESS_OPEN:
                    operation.pop("security", None)
                    for status in ("401", "403"):
                        operation.get("responses", {}).pop(status, None)
                elif access == ACCESS_OPEN_READS and open_reads:
                    operation["security"] = [{}, {"APIKeyHeader": []}]
                if access != ACCESS_OPEN and method.upper() in IDEMPOTENT_METHODS:
                    # the header every keyed write takes, as a parameter a generated client
                    # offers (it was only in the document's introduction: an API client's
                    # pass)
                    operation.setdefault("parameters", []).append(IDEMPOTENCY_PARAMETER)
        app.openapi_schema = schema
    return app.openapi_schema



def create_app(
    settings: Settings | None = None,
    *,
    clearance_estimator: ClearanceEstimator | None = None,
    prepare_store: bool = True,
) -> FastAPI:
    """Build the application.

    Parameters
    ----------
    settings
        Configuration; read from the environment when ``None``.
    clearance_estimator
        Computes clearances for table rows that lack one (see
        :class:`app.services.clearance.ClearanceEstimator`); ``None`` leaves them empty.
    prepare_store
        Migrate the store and preload the reference data at start-up.  ``hydrodiag serve``
        does that itself before it starts the server, and passes ``False``.

    Returns
    -------
    FastAPI
        The application; its store and job threads live from start-up to shutdown.
    """
    settings = settings or Settings()
    engine = make_engine(settings.url, lock_timeout_s=settings.db_lock_timeout)
    sessions = make_session_factory(engine)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if prepare_store:
            with bootstrap_lock(engine):
                upgrade_database(engine)
                with sessions() as session:
                    ensure_reference_data(session, estimator=clearance_estimator)
        with sessions() as session:
            interrupted = fail_interrupted_jobs(session)
        if interrupted:
            logger.warning("%d job(s) of an earlier run marked failed (cancelled, those asked "
                           "to stop)", interrupted)
        app.state.jobs = JobRunner(sessions, workers=settings.job_workers,
                                   max_queued=settings.max_queued_jobs,
                                   retention_days=settings.job_retention_days)
        loop, pool = asyncio.get_running_loop(), app.state.diagnosis_pool

        def warm(rigs: Sequence[ResolvedRig]) -> None:  # then watch the processes from the loop
            pool.warm(rigs)
            with contextlib.suppress(RuntimeError):  # the loop closed: the service stopped
                loop.call_soon_threadsafe(pool.attach)

        app.state.warmup = Warmup(sessions, app.state.rigs, settings.rig_cache_size,
                                  then=warm)
        app.state.warmup.start()
        try:
            yield
        finally:
            app.state.jobs.shutdown(wait=True)
            app.state.diagnosis_pool.shutdown()
            app.state.diagnosis_writer.shutdown()
            app.state.sweep_executors.shutdown()
            engine.dispose()
            gc.unfreeze()   # what start-up froze is collectable again (several apps: tests)

    # /docs and /redoc from files shipped with fastapi-offline, not a CDN: on a plant
    # network without the internet they were blank pages (a first-day user pass)
    app = FastAPIOffline(
        title="hydrodiag",
        version=__version__,
        description=_DESCRIPTION,
        lifespan=lifespan,
        static_url=DOCS_STATIC,
    )
    app.state.settings = settings
    app.state.engine = engine
    app.state.sessions = sessions
    app.state.clearance_estimator = clearance_estimator
    app.state.rigs = RigCache(settings.rig_cache_size)
    app.state.metrics = HttpMetrics()
    stages = app.state.metrics.diagnosis_stage
    app.state.diagnosis_pool = DiagnosisPool(
        settings.diagnosis_processes, settings.rig_cache_size, settings.diagnosis_queue,
        url=settings.url.render_as_string(hide_password=False), sessions=sessions,
        rigs=app.state.rigs, wait_budget_s=settings.diagnosis_wait_ms / 1e3,
        observe=lambda stage, seconds: stages.labels(stage).observe(seconds),
        on_restart=app.state.metrics.process_restarts.inc)
    app.state.diagnosis_writer = GroupCommitter(sessions)
    app.state.sweep_executors = SweepExecutors(workers=settings.sweep_workers,
                                               dask_scheduler=settings.dask_scheduler)
    app.state.failed_keys = KeyRateLimiter(FAILED_KEYS_PER_MINUTE)
    app.state.rate_limiter = (KeyRateLimiter(settings.rate_limit_per_minute)
                              if settings.rate_limit_per_minute else None)
    app.add_middleware(CatchAllMiddleware)  # innermost: a 500 logged once, with its id
    app.add_middleware(IdempotencyMiddleware, sessions=sessions,   # after the body limit
                       routes=app.router.routes)
    app.add_middleware(BodyLimitMiddleware, limit=settings.max_body_bytes,
                       upload_limit=settings.max_upload_bytes)
    app.add_middleware(MetricsMiddleware, metrics=app.state.metrics)
    app.add_middleware(RequestLogMiddleware, log=settings.access_log)  # outermost: ids on all
    install_error_handlers(app)
    app.include_router(api_router)
    app.include_router(console_router)
    app.openapi = lambda: _documented_openapi(app, settings.open_reads)  # type: ignore[method-assign]
    return app


def create_service_app() -> FastAPI:
    """The application as ``hydrodiag serve`` runs it, configured from the environment.

    It migrates the store and preloads the reference data at start-up as ``serve`` does
    (nothing to do when ``serve`` has done it before starting its workers), so
    ``uvicorn app.main:create_service_app --factory`` works on a fresh data folder; table
    rows without a clearance get one from
    :class:`~app.services.throttle_estimator.ThrottleClearanceEstimator`.  As a worker
    process of ``serve`` it ends itself when ``serve`` is gone (:mod:`app.lifeline`).  The
    ``hydrodiag`` log goes to standard error as ``HYDRODIAG_LOG_FORMAT`` says
    (:func:`app.logs.configure_logging`); run uvicorn with ``--no-access-log``, as the
    service writes its own access line per request.
    """
    from app.services.throttle_estimator import ThrottleClearanceEstimator

    supervisor = multiprocessing.parent_process()
    if supervisor is not None:  # a worker of `serve`: leave with it
        # its pid as spawn recorded it: a supervisor killed before this line (a slow start)
        # leaves us with init as parent, and watching "the current parent" would then
        # serve on as an orphan
        exit_with_parent(supervisor.pid)
    settings = Settings()
    configure_logging(settings.log_format, settings.log_level)
    return create_app(settings, clearance_estimator=ThrottleClearanceEstimator())
