"""Where ``POST /diagnose`` computes: diagnosis processes beside the event loop, or a thread.

A diagnosis is CPU-bound Python and compiled code.  Run in a thread of the server process
it holds the interpreter lock, and the event loop then waits up to the switch interval
(5 ms) at each of its steps: ``/health`` queued behind diagnoses for seconds under load
(issue 14).  :class:`DiagnosisPool` with ``processes`` ≥ 1 sends the work to that many
diagnosis processes of its own (:mod:`app.services.diagnosis_worker`), so that the server
process only parses, authenticates, stores and answers.  ``processes = 0`` computes in the
server's thread pool under :data:`~app.services.diagnosis.DIAGNOSIS_LOCK` (tests, small
machines).

Each process has one pipe to the server process, and the event loop reads the answers
from it itself (``loop.add_reader``): no executor thread between them.  A
``ProcessPoolExecutor`` took three thread hand-offs per task (its queue feeder, its result
manager, the loop's wake-up), each costing the event loop its interpreter lock, about a
tenth of the server process's CPU per request (profile of issue 9).  A process takes one
task at a time; the others wait in the pool's queue.

Admission (:meth:`DiagnosisPool.admit`): a server process takes at most ``queue``
``/diagnose`` requests at once, and refuses one more (503 with ``Retry-After``, before any
work) also when the expected wait for a diagnosis process — the requests in, divided among
the processes, times the measured time of one — is over ``wait_budget_s``: work the machine
cannot do in time is refused at once rather than queued past its client's patience, and
the event loop keeps time to answer ``/health``.

Processes are started with ``spawn`` (the server process has threads) and leave when the
server process is gone, even after a ``kill -9`` (they watch their parent); one that dies is
replaced, and the request it was computing is answered 503.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import contextvars
import logging
import multiprocessing
import os
import pickle
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

import anyio
import anyio.to_thread
from starlette.concurrency import run_in_threadpool

from app.db.engine import SessionFactory
from app.errors import ServiceBusyError, ServiceUnavailableError
from app.services.diagnosis import (
    DIAGNOSIS_LOCK,
    GroupPlan,
    GroupResult,
    compute_group,
    request_error,
)
from app.services.diagnosis_answer import DiagnoseAnswer
from app.services.diagnosis_pipes import READ_CHUNK, Process, Queued, send_whole, take_message
from app.services.diagnosis_task import DiagnoseTask, TaskFailure, run_task
from app.services.diagnosis_worker import MISSING, serve_pipe, warm_rig
from app.services.rig_cache import ResolvedRig, RigCache
from sim.errors import HydrodiagError, InputError

__all__ = ["DiagnosisPool", "warm_rig"]

logger = logging.getLogger("hydrodiag.app")

#: Longest wait for every process to start and warm [s].
_WARM_TIMEOUT_S = 300.0

#: Starts of a diagnosis process that dies before it is ready, in a row, before giving up.
_START_TRIES = 3

#: Threads of a server process that read and write the store for the console at once.
STORE_THREADS = 4

#: Weight of the newest task in the running mean of a task's time [-].
_SERVICE_TIME_WEIGHT = 0.1

#: First tasks of a process left out of the running mean (cold caches) [-].
_COLD_TASKS = 3

#: Largest sample of a task's time taken, over the running mean [-].
_SERVICE_TIME_CLAMP = 4.0

T = TypeVar("T")


class DiagnosisPool:
    """Computes diagnoses in ``processes`` diagnosis processes, or in a thread when 0.

    Parameters
    ----------
    processes
        Diagnosis processes [-]; 0 computes in the server's thread pool.
    cache_size
        Compiled rigs each process keeps [-].
    queue
        Most requests taken at once (running or waiting) [-].
    url
        Database URL the processes resolve rigs with (:meth:`diagnose`).
    sessions, rigs
        The server's store and compiled rigs, used by :meth:`diagnose` when ``processes``
        is 0.
    wait_budget_s
        Longest expected wait for a diagnosis process before a request is refused [s];
        ``None``: only ``queue`` bounds the requests taken.
    observe
        Told each task's stages (``queue``, ``compute``, ``transfer``) and their times
        [s] (:attr:`app.metrics.HttpMetrics.diagnosis_stage`); ``None``: not timed.
    """

    def __init__(self, processes: int, cache_size: int = 16, queue: int = 32, *,
                 url: str | None = None, sessions: SessionFactory | None = None,
                 rigs: RigCache | None = None, wait_budget_s: float | None = None,
                 observe: Callable[[str, float], None] | None = None,
                 on_restart: Callable[[], None] | None = None) -> None:
        if processes < 0 or queue < 1:
            raise ValueError("processes must be 0 or more, queue 1 or more")
        self.processes = processes
        self.queue = queue
        self.wait_budget_s = wait_budget_s
        self.admitted = 0
        #: Tasks computed so far (in the processes or the thread) [-].
        self.computed = 0
        #: Running mean of the time from sending a task to its answer [s].
        self.service_time_s = 0.0
        #: Requests refused by the expected wait (not by ``queue``) [-].
        self.refused_by_wait = 0
        self._cache_size = cache_size
        self._url = url
        self._sessions = sessions
        self._rigs = rigs
        self._workers: list[Process] = []
        self._warm: list[tuple[Any, Any]] = []
        self._pending: collections.deque[Queued] = collections.deque()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._lock = threading.Lock()
        self._limiter: anyio.CapacityLimiter | None = None
        self._observe = observe
        #: Called when a diagnosis process that stopped is replaced (a metrics counter).
        self._on_restart = on_restart

    # --- admission ---------------------------------------------------------------------

    def expected_wait_s(self) -> float:
        """Expected wait of one more request for a diagnosis process [s]: the tasks ahead
        of it (computing or queued), shared among the processes, times the running mean of
        a task's time from sending to answer (which counts the time the machine's other
        work takes the processes' cores)."""
        busy = sum(1 for w in self._workers if w.waiter is not None)
        return (busy + len(self._pending)) / max(self.processes, 1) * self.service_time_s

    @contextmanager
    def admit(self) -> Iterator[None]:
        """Count one request in for the length of the block, or refuse it (on the event
        loop only; no lock needed).

        Raises
        ------
        ServiceBusyError
            ``queue`` requests are in already, or the expected wait is over
            ``wait_budget_s`` (503 with ``Retry-After``): a request answered at once is
            better than one that waits past its deadline.
        """
        if self.admitted >= self.queue:
            raise ServiceBusyError(
                f"{self.admitted} diagnosis requests are already queued in this server "
                "process (setting HYDRODIAG_DIAGNOSIS_QUEUE); retry shortly", retry_after=1)
        if self.wait_budget_s is not None and self.expected_wait_s() > self.wait_budget_s:
            self.refused_by_wait += 1
            raise ServiceBusyError(
                f"a diagnosis would wait about {1e3 * self.expected_wait_s():.0f} ms here, "
                f"over {1e3 * self.wait_budget_s:.0f} ms (setting "
                "HYDRODIAG_DIAGNOSIS_WAIT_MS); retry shortly", retry_after=1)
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

    # --- the processes -----------------------------------------------------------------

    def _spawn(self) -> Process:
        context = multiprocessing.get_context("spawn")
        mine, theirs = context.Pipe(duplex=True)
        process = context.Process(
            target=serve_pipe, name="hydrodiag-diagnosis", daemon=True,
            args=(theirs, self._url, self._cache_size, os.getpid(), self._warm))
        process.start()
        theirs.close()
        return Process(process, mine)

    def _start(self) -> None:
        with self._lock:
            while len(self._workers) < self.processes:
                self._workers.append(self._spawn())

    def _wait_ready(self, timeout: float = _WARM_TIMEOUT_S) -> None:
        """Read each process's ``ready`` (before the event loop reads their pipes); one
        that dies before it is ready is replaced, :data:`_START_TRIES` times in a row at
        most.  (One killed while warming (out of memory, a crash) left a pipe whose read
        raised ``EOFError`` on every later request: 500 for every ``/diagnose``, for
        ever, with ``/ready`` at 200 — an operator pass.)"""
        deadline = time.monotonic() + timeout
        with self._lock:
            for index, worker in enumerate(self._workers):
                if worker.ready or self._loop is not None:
                    continue
                for _ in range(_START_TRIES):
                    if not worker.connection.poll(max(deadline - time.monotonic(), 0.0)):
                        raise ServiceUnavailableError(
                            "a diagnosis process did not start in time")
                    try:
                        ready = pickle.loads(worker.connection.recv_bytes())
                    except (EOFError, OSError):   # it died before it was ready
                        logger.error("a diagnosis process (pid %s) stopped while starting; "
                                     "starting another", worker.process.pid)
                        worker.connection.close()
                        worker.process.join(timeout=5.0)   # no zombie left behind
                        worker = self._workers[index] = self._spawn()
                        if self._on_restart is not None:
                            self._on_restart()
                        continue
                    worker.ready, worker.pid = True, ready[1]
                    break
                else:
                    raise ServiceUnavailableError(
                        f"the diagnosis processes stopped while starting, {_START_TRIES} "
                        "times in a row: see the service log")

    def warm(self, rigs: Sequence[ResolvedRig]) -> None:
        """Start every process and warm ``rigs`` in each (blocks until all are warm; not
        on the event loop)."""
        if self.processes == 0:
            for resolved in rigs:
                with DIAGNOSIS_LOCK:
                    warm_rig(resolved.rig)
            return
        self._warm = [(r.key, dict(r.document)) for r in rigs]
        self._start()
        self._wait_ready()
        logger.info("%d diagnosis process(es) warm", len(self._workers))

    def worker_pids(self) -> list[int]:
        """Process ids of the diagnosis processes, once started (blocks until they are)."""
        self._start()
        self._wait_ready()
        return [w.pid for w in self._workers if w.pid is not None]

    def attach(self) -> None:
        """Read the pipes from the running event loop now, not at the first request: a
        process that dies before then is replaced when it dies (it was found by that
        request, answered 500; /ready said 200 meanwhile: an operator's pass)."""
        if self.processes:
            self._attach()

    def _attach(self) -> None:
        """Read the pipes from the running event loop (again after a new loop: tests)."""
        loop = asyncio.get_running_loop()
        if self._loop is loop:
            return
        with self._lock:
            self._loop = loop
            for worker in self._workers:
                self._read(worker)

    def _on_answer(self, worker: Process) -> None:
        """Read what the pipe holds (never blocking: uvloop makes the descriptor
        non-blocking) and handle each whole message in it."""
        try:
            chunk = os.read(worker.connection.fileno(), READ_CHUNK)
        except BlockingIOError:
            return
        except OSError:
            chunk = b""
        if not chunk:  # the process is gone
            self._replace(worker)
            return
        worker.buffer += chunk
        while (message := take_message(worker.buffer)) is not None:
            seconds, result = pickle.loads(message)
            if not worker.ready:  # a replacement process's "ready"
                worker.ready, worker.pid = True, result
                continue
            waiter, worker.waiter = worker.waiter, None
            elapsed = time.perf_counter() - worker.sent_at
            self._learn(worker, elapsed)
            if self._observe is not None:
                self._observe("compute", seconds)
                self._observe("transfer", max(elapsed - seconds, 0.0))
            if waiter is not None and not waiter.done():
                waiter.set_result(result)
        self._dispatch()

    def _learn(self, worker: Process, elapsed: float) -> None:
        """Update the running mean of a task's time with ``elapsed`` [s].  A process's
        first tasks (cold caches: up to a second) are left out, and a sample is taken at
        most :data:`_SERVICE_TIME_CLAMP` times the mean, so that one slow task (a batch, a
        new rig) does not close admission for the many that follow."""
        worker.done += 1
        if worker.done <= _COLD_TASKS:
            return
        if self.service_time_s > 0:
            elapsed = min(elapsed, _SERVICE_TIME_CLAMP * self.service_time_s)
            self.service_time_s += _SERVICE_TIME_WEIGHT * (elapsed - self.service_time_s)
        else:
            self.service_time_s = elapsed

    def _replace(self, gone: Process) -> None:
        """A process died: answer its task 503 and start another in its place."""
        assert self._loop is not None
        self._loop.remove_reader(gone.connection.fileno())
        gone.connection.close()
        logger.error("a diagnosis process (pid %s) stopped; starting another", gone.pid)
        if gone.waiter is not None and not gone.waiter.done():
            gone.waiter.set_exception(ServiceUnavailableError(
                "the diagnosis process computing this request stopped; retry"))
        with self._lock:
            index = self._workers.index(gone)
            self._workers[index] = worker = self._spawn()
        if self._on_restart is not None:
            self._on_restart()
        self._read(worker)

    def _read(self, worker: Process) -> None:
        """Read ``worker``'s pipe from the loop, in a context of its own: the reader took
        the context of the request that first reached the pool, and its log lines (a
        process that stopped) named that request's id, minutes later."""
        assert self._loop is not None
        contextvars.Context().run(self._loop.add_reader, worker.connection.fileno(),
                                  self._on_answer, worker)

    def _dispatch(self) -> None:
        for worker in self._workers:
            if not self._pending:
                return
            if worker.ready and worker.waiter is None:
                queued = self._pending.popleft()
                try:
                    send_whole(worker.connection, queued.message)
                except OSError:
                    # the process died while idle (its pipe broken before its end was read):
                    # the request, not started, waits for another process; the dead one is
                    # replaced (it was a 500 BrokenPipeError: an operator's pass)
                    self._pending.appendleft(queued)
                    self._replace(worker)
                    continue
                worker.waiter, worker.sent_at = queued.future, time.perf_counter()
                if self._observe is not None:
                    self._observe("queue", worker.sent_at - queued.queued_at)

    async def _call(self, kind: str, payload: Any) -> Any:
        if not self._workers or (self._loop is None
                                 and not all(w.ready for w in self._workers)):
            await asyncio.to_thread(self.worker_pids)
        self._attach()
        assert self._loop is not None
        future: asyncio.Future[Any] = self._loop.create_future()
        message = pickle.dumps((kind, payload), protocol=pickle.HIGHEST_PROTOCOL)
        self._pending.append(Queued(message, future, time.perf_counter()))
        self._dispatch()
        return await future

    # --- the work ----------------------------------------------------------------------

    async def diagnose(self, task: DiagnoseTask) -> DiagnoseAnswer:
        """Resolve, diagnose and serialise one ``POST /diagnose``
        (:func:`app.services.diagnosis_task.run_task`).

        Raises
        ------
        HydrodiagError
            As the request's answer: unknown rig or version (404), a record impossible on
            its rig (422), the field a path in the request.
        """
        self.computed += 1
        if self.processes == 0:
            if self._sessions is None or self._rigs is None:
                raise RuntimeError("a pool without processes needs sessions and rigs")
            sessions, rigs = self._sessions, self._rigs

            def locked() -> DiagnoseAnswer | TaskFailure:
                with DIAGNOSIS_LOCK:
                    return run_task(sessions, rigs, task)
            answer = await run_in_threadpool(locked)
        else:
            answer = await self._call("request", task)
        if isinstance(answer, TaskFailure):
            raise answer.error()
        assert isinstance(answer, DiagnoseAnswer)
        return answer

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
        # the rig's key only: its ~6 kB document is pickled and sent again only to a
        # process that has not compiled it yet (a rig created after start, or evicted)
        answer = await self._call("group", (plan.resolved.key, None, plan.records))
        if answer == MISSING:
            answer = await self._call("group", (plan.resolved.key,
                                                dict(plan.resolved.document), plan.records))
        if isinstance(answer, TaskFailure):
            error: HydrodiagError = answer.error()
            if isinstance(error, InputError):
                raise request_error(error, plan) from None
            raise error
        assert isinstance(answer, GroupResult)
        return answer

    def shutdown(self) -> None:
        """Stop the processes (a running diagnosis finishes first)."""
        with self._lock:
            workers, self._workers = self._workers, []
            loop, self._loop = self._loop, None
        for worker in workers:
            if loop is not None and not loop.is_closed():
                with contextlib.suppress(RuntimeError, ValueError, OSError):
                    loop.remove_reader(worker.connection.fileno())  # not on its thread
            worker.connection.close()  # the process leaves at its next read
        for worker in workers:
            worker.process.join(timeout=30)
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join(timeout=5)
