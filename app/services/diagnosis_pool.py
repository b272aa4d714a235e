"""Where ``POST /diagnose`` computes: worker processes beside the event loop, or a thread.

A diagnosis is CPU-bound Python and compiled code.  Run in a thread of the server process
it holds the interpreter lock, and the event loop then waits up to the switch interval
(5 ms) at each of its steps: ``/health`` queued behind diagnoses for seconds under load
(issue 14).  :class:`DiagnosisPool` with ``processes`` ≥ 1 sends the computation
(:func:`app.services.diagnosis.compute_group`) to that many worker processes of its own,
so the server process only parses, authenticates, stores and answers, and its event loop
keeps its interpreter lock.  ``processes = 0`` computes in the server's thread pool under
:data:`~app.services.diagnosis.DIAGNOSIS_LOCK`, as before (tests, small machines).

Each worker keeps its own compiled rigs (an LRU keyed by rig id, version and the version's
creation time, the key of :class:`~app.services.rig_cache.RigCache`); a task carries the
key only, and a worker that lacks the rig answers so, and is sent the task again with
the rig document (compiled there once).  :meth:`DiagnosisPool.warm` starts
every worker and loads and exercises the stored rigs in it (one steady cycle and one
diagnosis each) before the service reports ready.  Workers are started with ``spawn``
(the server process has threads) and leave when the server process is gone, even after a
``kill -9`` (they watch their parent).
"""

from __future__ import annotations

import asyncio
import logging
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any, TypeVar

import anyio
import anyio.to_thread
from starlette.concurrency import run_in_threadpool

from app.errors import ServiceBusyError
from app.lifeline import exit_with_parent
from app.services.diagnosis import (
    DIAGNOSIS_LOCK,
    GroupPlan,
    GroupResult,
    compute_group,
    request_error,
)
from app.services.rig_cache import ResolvedRig
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from sim.errors import HydrodiagError, InputError
from sim.rigs import Rig, load_rig
from sim.steady import steady_cycle

__all__ = ["DiagnosisPool", "RigKey", "warm_rig"]

logger = logging.getLogger("hydrodiag.app")

#: Longest wait for every worker to start and warm [s].
_WARM_TIMEOUT_S = 300.0

#: Threads of a server process that read and write the store for /diagnose at once.
STORE_THREADS = 4

RigKey = tuple[int, int, datetime]
T = TypeVar("T")


def warm_rig(rig: Rig) -> None:
    """Call the compiled code a diagnosis uses once on ``rig``: a steady cycle at the
    rig's default condition, then a diagnosis of the velocity ratio it predicts."""
    condition = rig.default_condition()
    ratio = steady_cycle(rig, condition=condition).velocity_ratio
    if not ratio > 0:  # the piston stalls at the default condition: nothing to diagnose
        return
    load = ({"back_pressure": condition.back_pressure} if condition.back_pressure
            else {"load_force": condition.load})
    record = MeasurementRecord.from_readings(
        "warm-up", OperatingCondition.from_readings(
            {"oil_temperature": condition.oil_temperature} | load),
        {"velocity_ratio": ratio}, rig_name="warm-up", taken_at=datetime.now(UTC))
    compute_group(rig, [record], 1)


# --- in the worker processes -------------------------------------------------------------

_RIGS: dict[RigKey, Rig] = {}
_RIG_ORDER: list[RigKey] = []
_CACHE_SIZE = 16


def _worker_start(cache_size: int, parent: int, rigs: Sequence[tuple[RigKey, Any]]) -> None:
    """Initialiser of a worker: remember the cache size, watch the parent, warm the rigs."""
    global _CACHE_SIZE
    _CACHE_SIZE = cache_size
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C stops the server, which stops us
    exit_with_parent(parent)
    for key, document in rigs:
        try:
            rig = _worker_rig(key, document)
            assert rig is not None  # compiled from its document
            warm_rig(rig)
        except HydrodiagError as exc:  # a rig that cannot run still answers 422s
            logger.warning("rig %s not warmed in a diagnosis worker: %s", key[0], exc)


def _worker_rig(key: RigKey, document: Mapping[str, Any] | None) -> Rig | None:
    """The compiled rig of ``key``, compiled from ``document`` on a miss; ``None`` on a
    miss without the document."""
    rig = _RIGS.get(key)
    if rig is None:
        if document is None:
            return None
        rig = _RIGS[key] = load_rig(document)
        _RIG_ORDER.append(key)
        while len(_RIG_ORDER) > _CACHE_SIZE:
            _RIGS.pop(_RIG_ORDER.pop(0), None)
    return rig


@dataclass(frozen=True, slots=True)
class _Failure:
    """An error of the library, carried back as plain data (its ``field`` survives)."""

    kind: type[HydrodiagError]
    message: str
    field: str | None


#: The answer of a worker that lacks the rig and was not sent its document.
_MISSING = "rig document needed"


def _worker_compute(key: RigKey, document: Mapping[str, Any] | None,
                    records: list[MeasurementRecord]) -> GroupResult | _Failure | str:
    try:
        rig = _worker_rig(key, document)
        if rig is None:
            return _MISSING
        return compute_group(rig, records, key[1])
    except HydrodiagError as exc:
        return _Failure(type(exc), exc.message, exc.field)


def _worker_pid() -> int:
    time.sleep(0.05)  # long enough that the other workers take the other probes
    return os.getpid()


# --- in the server process ---------------------------------------------------------------


def _key(resolved: ResolvedRig) -> RigKey:
    return (resolved.rig_id, resolved.version, resolved.created_at)


class DiagnosisPool:
    """Computes diagnoses in ``processes`` worker processes, or in a thread when 0.

    Parameters
    ----------
    processes
        Worker processes [-]; 0 computes in the server's thread pool.
    cache_size
        Compiled rigs each worker keeps [-].
    """

    def __init__(self, processes: int, cache_size: int = 16, queue: int = 32) -> None:
        if processes < 0 or queue < 1:
            raise ValueError("processes must be 0 or more, queue 1 or more")
        self.processes = processes
        self.queue = queue
        self.admitted = 0
        #: Groups computed so far (in the workers or the thread) [-].
        self.computed = 0
        self._cache_size = cache_size
        self._executor: ProcessPoolExecutor | None = None
        self._lock = threading.Lock()
        self._limiter: anyio.CapacityLimiter | None = None

    @contextmanager
    def admit(self) -> Iterator[None]:
        """Count one request in for the length of the block, or refuse it when ``queue``
        requests are already in (on the event loop only; no lock needed).

        Raises
        ------
        ServiceBusyError
            As many requests are in as the setting allows (503 with ``Retry-After``): a
            request answered at once is better than one that waits past its deadline.
        """
        if self.admitted >= self.queue:
            raise ServiceBusyError(
                f"{self.admitted} diagnosis requests are already queued in this server "
                "process (setting HYDRODIAG_DIAGNOSIS_QUEUE); retry shortly", retry_after=1)
        self.admitted += 1
        try:
            yield
        finally:
            self.admitted -= 1

    async def in_thread(self, call: Callable[[], T]) -> T:
        """Run ``call`` (store reads and writes) in the thread pool, at most
        :data:`STORE_THREADS` at once: more threads would only contend for the interpreter
        lock with the event loop."""
        if self._limiter is None:
            self._limiter = anyio.CapacityLimiter(STORE_THREADS)
        return await anyio.to_thread.run_sync(call, limiter=self._limiter)

    def _pool(self, rigs: Sequence[ResolvedRig] = ()) -> ProcessPoolExecutor:
        with self._lock:
            if self._executor is None:
                self._executor = ProcessPoolExecutor(
                    max_workers=self.processes,
                    mp_context=multiprocessing.get_context("spawn"),
                    initializer=_worker_start,
                    initargs=(self._cache_size, os.getpid(),
                              [(_key(r), dict(r.document)) for r in rigs]))
            return self._executor

    def warm(self, rigs: Sequence[ResolvedRig]) -> None:
        """Start every worker and warm ``rigs`` in each (blocks until all are warm).

        Each worker runs the warm-up in its initialiser, before it takes any task; the
        probes here return once every worker has answered one, so all have started.
        """
        if self.processes == 0:
            for resolved in rigs:
                with DIAGNOSIS_LOCK:
                    warm_rig(resolved.rig)
            return
        pool = self._pool(rigs)
        seen: set[int] = set()
        deadline = time.monotonic() + _WARM_TIMEOUT_S
        while len(seen) < self.processes and time.monotonic() < deadline:
            probes = [pool.submit(_worker_pid) for _ in range(self.processes)]
            seen |= {probe.result(timeout=_WARM_TIMEOUT_S) for probe in probes}
        logger.info("%d diagnosis worker(s) warm", len(seen))

    async def compute(self, plan: GroupPlan) -> GroupResult:
        """Diagnose one planned group; errors name their field in the request.

        Raises
        ------
        InputError
            The records cannot be diagnosed on their rig.
        """
        self.computed += 1
        if self.processes == 0:
            def locked() -> GroupResult:
                with DIAGNOSIS_LOCK:
                    return compute_group(plan.resolved.rig, plan.records,
                                         plan.resolved.version)
            try:
                return await run_in_threadpool(locked)
            except InputError as exc:
                raise request_error(exc, plan) from None
        loop = asyncio.get_running_loop()
        # the rig's key only: its ~6 kB document is pickled and sent again only to a
        # worker that has not compiled it yet (a rig created after start, or evicted)
        answer = await loop.run_in_executor(
            self._pool(), _worker_compute, _key(plan.resolved), None, plan.records)
        if isinstance(answer, str):  # _MISSING
            answer = await loop.run_in_executor(
                self._pool(), _worker_compute, _key(plan.resolved),
                dict(plan.resolved.document), plan.records)
        assert not isinstance(answer, str)
        if isinstance(answer, _Failure):
            error = answer.kind(answer.message, field=answer.field)
            if isinstance(error, InputError):
                raise request_error(error, plan) from None
            raise error
        return answer

    def shutdown(self) -> None:
        """Stop the workers (the running diagnoses finish first)."""
        with self._lock:
            executor, self._executor = self._executor, None
        if executor is not None:
            executor.shutdown(wait=True, cancel_futures=True)

