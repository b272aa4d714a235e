"""The FastAPI application: :func:`create_app` wires settings, store, jobs and routes.

``uvicorn app.main:create_service_app --factory`` serves it as ``hydrodiag serve`` does,
minus the migration, the preloading and the first-start API key (``hydrodiag db upgrade``,
``hydrodiag keys create``); ``serve`` uses that factory itself for several workers.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI

from app import __version__
from app.api.router import api_router
from app.console import router as console_router
from app.db.engine import make_engine, make_session_factory
from app.errors import install_error_handlers
from app.metrics import HttpMetrics, MetricsMiddleware
from app.services.bootstrap import ensure_reference_data, upgrade_database
from app.services.clearance import ClearanceEstimator
from app.services.executors import SweepExecutors
from app.services.jobs import JobRunner, fail_interrupted_jobs
from app.services.rig_cache import RigCache
from app.settings import Settings

__all__ = ["create_app", "create_service_app"]

logger = logging.getLogger("hydrodiag.app")

_DESCRIPTION = """\
Fault diagnosis of hydraulic rigs from bond-graph models.

Every quantity is in SI units, named in brackets in each field's description.  Reads are
open unless the service runs with `HYDRODIAG_OPEN_READS=false`; anything that stores or
changes data needs an API key in the `X-API-Key` header.  Errors have one body:
`{"error": {"type": ..., "message": ..., "field": ...}}`.
"""


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
    engine = make_engine(settings.url)
    sessions = make_session_factory(engine)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if prepare_store:
            upgrade_database(engine)
            with sessions() as session:
                ensure_reference_data(session, estimator=clearance_estimator)
        with sessions() as session:
            interrupted = fail_interrupted_jobs(session)
        if interrupted:
            logger.warning("%d job(s) of an earlier run marked failed", interrupted)
        app.state.jobs = JobRunner(sessions, workers=settings.job_workers)
        try:
            yield
        finally:
            app.state.jobs.shutdown(wait=True)
            app.state.sweep_executors.shutdown()
            engine.dispose()

    app = FastAPI(
        title="hydrodiag",
        version=__version__,
        description=_DESCRIPTION,
        lifespan=lifespan,
    )
    app.state.settings = settings
    app.state.engine = engine
    app.state.sessions = sessions
    app.state.clearance_estimator = clearance_estimator
    app.state.rigs = RigCache(settings.rig_cache_size)
    app.state.sweep_executors = SweepExecutors(workers=settings.sweep_workers,
                                               dask_scheduler=settings.dask_scheduler)
    app.state.metrics = HttpMetrics()
    app.add_middleware(MetricsMiddleware, metrics=app.state.metrics)
    install_error_handlers(app)
    app.include_router(api_router)
    app.include_router(console_router)
    return app


def create_service_app() -> FastAPI:
    """The application as ``hydrodiag serve`` runs it, configured from the environment.

    The store is expected migrated and preloaded (``serve`` does it once before its
    workers start); table rows without a clearance get one from
    :class:`~app.services.throttle_estimator.ThrottleClearanceEstimator`.
    """
    from app.services.throttle_estimator import ThrottleClearanceEstimator

    return create_app(Settings(), clearance_estimator=ThrottleClearanceEstimator(),
                      prepare_store=False)
