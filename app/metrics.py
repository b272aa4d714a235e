"""Prometheus metrics of the service: request count and latency per route, and the stages
of ``POST /diagnose``.

The route label is the path *template* (``/rigs/{rig_id}``), so the number of series stays
bounded whatever ids clients use (a request answered before routing, such as an
``Idempotency-Key`` replay, is matched to its template afterwards); requests that match no
route count as ``<unmatched>``.
Each application has its own registry, so several can live in one process (tests).

``hydrodiag serve`` with several worker processes (:func:`shared_metrics`) runs
prometheus_client's multiprocess mode: each worker writes its values to files in one
folder (``PROMETHEUS_MULTIPROC_DIR``), and a scrape, whichever worker answers it, reads the
sum of all (:func:`exposition`).  Before, a scrape showed the counters of the one worker
that answered it, so a counter went up and down from scrape to scrape (an operator pass).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
import weakref
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

from prometheus_client import CollectorRegistry, Counter, Histogram, generate_latest
from starlette.routing import BaseRoute, Match, Route
from starlette.types import ASGIApp, Receive, Scope, Send

from app.logs import AnswerWatch

__all__ = ["MULTIPROCESS_DIR", "STARTED", "HttpMetrics", "MetricsMiddleware", "exposition",
           "shared_metrics"]

#: prometheus_client's variable: the folder where every process writes its values
MULTIPROCESS_DIR = "PROMETHEUS_MULTIPROC_DIR"


@contextmanager
def shared_metrics() -> Iterator[str]:
    """Run the worker processes started inside in multiprocess mode, in a new folder
    removed after (an operator's own ``PROMETHEUS_MULTIPROC_DIR`` is used and kept).

    prometheus_client chooses where values live when it is first imported, so the folder
    must be in the environment before the workers start (they are spawned, and import it
    afresh); this process itself answers no scrape.
    """
    own = os.environ.get(MULTIPROCESS_DIR)
    if own:
        yield own
        return
    _remove_orphans()
    folder = tempfile.mkdtemp(prefix=f"{_PREFIX}{os.getpid()}-")
    os.environ[MULTIPROCESS_DIR] = folder
    try:
        yield folder
    finally:
        os.environ.pop(MULTIPROCESS_DIR, None)
        shutil.rmtree(folder, ignore_errors=True)


#: Name of a metrics folder: the prefix, the serving process's id, a random part.
_PREFIX = "hydrodiag-metrics-"


def _remove_orphans() -> None:
    """Remove the metrics folders of ``serve`` processes that no longer run: a kill -9
    left its folder in the temporary directory, and a crash loop piles them up (an operator
    pass found 20)."""
    root = tempfile.gettempdir()
    for name in os.listdir(root):
        if not name.startswith(_PREFIX):
            continue
        pid = name[len(_PREFIX):].split("-", 1)[0]
        if not pid.isdigit() or _alive(int(pid)):
            continue
        shutil.rmtree(os.path.join(root, name), ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:   # another user's process: alive
        return True
    return True


def exposition(registry: CollectorRegistry) -> bytes:
    """The Prometheus text of ``registry``, or of every worker's values in multiprocess
    mode (:func:`shared_metrics`)."""
    if os.environ.get(MULTIPROCESS_DIR):
        from prometheus_client.multiprocess import MultiProcessCollector

        merged = CollectorRegistry()
        MultiProcessCollector(merged)
        return generate_latest(merged)
    return generate_latest(registry)

#: Key in ``request.state`` of the time the request arrived [s, ``time.perf_counter``].
STARTED = "hydrodiag_started"


class HttpMetrics:
    """The collectors of one application, in their own registry."""

    def __init__(self) -> None:
        self.registry = CollectorRegistry()
        self.requests = Counter(
            "hydrodiag_http_requests",
            "HTTP requests answered, by method, route template and status",
            ["method", "route", "status"],
            registry=self.registry,
        )
        self.latency = Histogram(
            "hydrodiag_http_request_duration_seconds",
            "Time to answer an HTTP request [s], by method and route template",
            ["method", "route"],
            registry=self.registry,
        )
        #: Where a ``POST /diagnose`` waits (issue 9): ``queue`` from its arrival at the
        #: pool to its send to a free diagnosis process, ``compute`` in that process (as
        #: the process timed it), ``transfer`` the rest of the round trip (pipes, pickling,
        #: the wake-ups of both ends), ``commit`` from handing its rows to the group commit
        #: to that transaction's commit; ``request`` the whole of a stored diagnosis's
        #: request, from its arrival to its answer.
        #: Diagnosis processes that stopped and were replaced (an operator pass: one
        #: killed while it warmed left every /diagnose failing, and nothing showed it).
        self.process_restarts = Counter(
            "hydrodiag_diagnosis_process_restarts",
            "Diagnosis processes that stopped (killed, out of memory) and were replaced",
            registry=self.registry,
        )
        self.diagnosis_stage = Histogram(
            "hydrodiag_diagnosis_stage_seconds",
            "Time a POST /diagnose spends in each stage [s]: queue (for a diagnosis "
            "process), compute (in it), transfer (pipes and wake-ups), commit (group commit), "
            "request (the whole of a stored diagnosis)",
            ["stage"],
            registry=self.registry,
            buckets=(0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0),
        )


#: Per application, its routes with a path template, nested routers flattened.
_ROUTES: weakref.WeakKeyDictionary[Any, list[BaseRoute]] = weakref.WeakKeyDictionary()


def _flat(routes: Iterable[Any]) -> Iterator[BaseRoute]:
    for route in routes:
        inner = getattr(route, "original_router", None)   # an included router (FastAPI)
        if inner is not None:
            yield from _flat(inner.routes)
        elif isinstance(route, Route):
            yield route


def _template(scope: Scope) -> str | None:
    """The template of the route ``scope`` goes to, for a request answered before routing
    (an ``Idempotency-Key`` replay, its 409 and 422, a body over the limit): those counted
    as ``<unmatched>``, so an operator saw no retries per route (a fleet pass)."""
    app = scope.get("app")
    if app is None or not hasattr(app, "router"):
        return None
    routes = _ROUTES.get(app)
    if routes is None:
        routes = _ROUTES.setdefault(app, list(_flat(app.router.routes)))
    for route in routes:
        match, _ = route.matches(scope)
        if match is Match.FULL:
            return str(getattr(route, "path_format", None) or getattr(route, "path", ""))
    return None


def _route_of(scope: Scope) -> str:
    route: Any = scope.get("route")
    # the template without converters: /pump-sets/{pump_set_id}, not {pump_set_id:int}
    path = getattr(route, "path_format", None) or getattr(route, "path", None)
    return str(path) if path else _template(scope) or "<unmatched>"


class MetricsMiddleware:
    """ASGI middleware that counts and times every HTTP request."""

    def __init__(self, app: ASGIApp, metrics: HttpMetrics) -> None:
        self.app = app
        self.metrics = metrics

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        start = time.perf_counter()
        scope.setdefault("state", {})[STARTED] = start  # request.state.<STARTED>
        watch = AnswerWatch(receive, send)   # a client gone before its answer: 499
        try:
            await self.app(scope, watch.receive, watch.send)
        finally:
            route, method = _route_of(scope), str(scope.get("method", ""))
            self.metrics.latency.labels(method, route).observe(time.perf_counter() - start)
            self.metrics.requests.labels(method, route, str(watch.status)).inc()
