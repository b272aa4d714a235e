"""Where sweeps run: a :class:`concurrent.futures.Executor`, local or on a Dask cluster.

Sweeps only use ``executor.submit(fn, *args)`` and :func:`concurrent.futures.as_completed`,
so one code path serves both kinds:

* **local** (default) — a :class:`~concurrent.futures.ProcessPoolExecutor` of
  ``HYDRODIAG_SWEEP_WORKERS`` processes (default: one per usable core,
  :func:`app.cgroup_limits.usable_cores`), started with ``spawn``
  (the service has threads; forking them is unsafe) on the first sweep and kept for the
  next ones, so the import of :mod:`sim` is paid once per worker;
* **Dask** — when ``HYDRODIAG_DASK_SCHEDULER`` names a scheduler (``tcp://host:8786``) and
  ``dask.distributed`` is importable, a :class:`distributed.Client` connects to it and its
  ``get_executor()`` is used: a genuine ``concurrent.futures.Executor`` whose futures work
  with ``as_completed``.  The workers need this hydrodiag installed (they import
  :mod:`app.services.sweep_worker`, which loads only ``sim``): at connection each worker's
  code fingerprint is compared with the service's and a cluster without a worker refused
  (:func:`_checked_workers`); a client the scheduler's absence closed is connected again
  (:meth:`SweepExecutors.get`); while results do not come, :meth:`SweepExecutors.check`
  fails work whose cluster has lost every worker.  Without the package the setting is
  ignored with a warning and the local pool is used.
"""

from __future__ import annotations

import importlib.util
import logging
import multiprocessing
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any, Literal

from app.cgroup_limits import usable_cores
from app.errors import ServiceUnavailableError
from app.lifeline import exit_with_parent
from diagnostics.batch import executor_workers

__all__ = ["CONNECT_TIMEOUT_S", "NO_WORKER_S", "SETTING", "Connection", "ExecutorKind",
           "ExecutorState", "SweepExecutors", "dask_available"]

logger = logging.getLogger("hydrodiag.app")

#: how long a connection to the Dask scheduler may take [s] (Dask's default 30 s held
#: each job, one after the other, and a SIGTERM past docker's 10 s: a Dask pass)
CONNECT_TIMEOUT_S = 5.0
#: how long work waits on a cluster without a worker before it fails [s]
NO_WORKER_S = 30.0
#: the service's setting of the scheduler's address, named by its errors by default
SETTING = "HYDRODIAG_DASK_SCHEDULER"


def _connected(scheduler: str, setting: str = SETTING) -> Any:
    """A client of the Dask scheduler at ``scheduler`` whose workers run this code;
    errors name ``setting``, where the address came from."""
    from distributed import Client

    try:
        client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as exc:   # "internal error; see the service log" before
        raise ServiceUnavailableError(
            f"the Dask scheduler {scheduler} does not answer ({exc}); start it or correct "
            f"{setting}", field=setting) from None
    try:
        _checked_workers(client, scheduler, setting)
    except BaseException:
        client.close()
        raise
    return client


def _checked_workers(client: Any, scheduler: str, setting: str = SETTING) -> None:
    """Refuse a cluster without a worker, one whose workers cannot import hydrodiag, or
    one whose workers run other hydrodiag code (:func:`~app.services.code_version.
    code_fingerprint`): such a worker died on its first task and the work waited for
    ever, or answered other numbers without a word (a Dask pass).  The errors name
    ``setting``."""
    from app.services.code_version import code_fingerprint

    if not client.nthreads():
        raise ServiceUnavailableError(
            f"the Dask cluster at {scheduler} has no worker: start workers (dask worker "
            f"{scheduler}) where this hydrodiag is installed", field=setting)
    try:
        theirs: dict[str, str] = client.run(code_fingerprint)
    except Exception as exc:  # a worker's failure, whatever it raised
        raise ServiceUnavailableError(
            f"a worker of the Dask cluster at {scheduler} cannot run hydrodiag "
            f"({type(exc).__name__}: {exc}); install this hydrodiag on every worker",
            field=setting) from None
    ours = code_fingerprint()
    other = sorted(worker for worker, print_ in theirs.items() if print_ != ours)
    if other:
        raise ServiceUnavailableError(
            f"{len(other)} of {len(theirs)} workers of the Dask cluster at {scheduler} run "
            f"other hydrodiag code than this service ({', '.join(other[:3])}): their "
            "results would differ; install the same version on every worker",
            field=setting)

ExecutorKind = Literal["processes", "dask"]
#: where the executor stands: ``local`` (a process pool), ``idle`` (a Dask scheduler set,
#: no connection yet: the first sweep connects), ``connected``, ``reconnecting`` (the
#: client lost the scheduler and tries again), ``closed`` (the next sweep connects again),
#: ``not answering`` (connected, but the scheduler did not answer the question in time)
Connection = Literal["local", "idle", "connected", "reconnecting", "closed", "not answering"]


@dataclass(frozen=True)
class ExecutorState:
    """What an operator asks of the sweeps' executor (``/ready``, ``/metrics``).

    Attributes
    ----------
    kind
        ``processes`` or ``dask``.
    scheduler
        The Dask scheduler's address, or None for the local pool.
    connection
        :data:`Connection`.
    workers
        Processes of the local pool (whether started or not), or the Dask cluster's
        workers when connected and answering; None when not known [-].
    threads
        Tasks run at once: the pool's processes or the cluster's worker threads; None when
        not known [-].
    """

    kind: ExecutorKind
    scheduler: str | None
    connection: Connection
    workers: int | None
    threads: int | None


def dask_available() -> bool:
    """Whether ``dask.distributed`` can be imported here."""
    return importlib.util.find_spec("distributed") is not None


class SweepExecutors:
    """Hands out the executor of the sweeps, created on first use and kept.

    Parameters
    ----------
    workers
        Processes of the local pool; ``None``: one per usable core (its CPU affinity and
        its control group's quota, :func:`app.cgroup_limits.usable_cores`).
    dask_scheduler
        Address of a Dask scheduler; ``None`` for the local pool.
    setting
        Where the address came from, named by the errors about the scheduler: the
        service's variable (:data:`SETTING`) or a command's option (``diagnose-batch
        --dask`` was told to correct the variable it had not used: a review's leftover).
    """

    def __init__(self, *, workers: int | None = None, dask_scheduler: str | None = None,
                 setting: str = SETTING) -> None:
        self._workers = workers or usable_cores()
        self._scheduler = dask_scheduler if dask_scheduler else None
        self._setting = setting
        if self._scheduler is not None and not dask_available():
            logger.warning("%s is set but dask.distributed is not installed; sweeps run on "
                           "local processes", setting)
            self._scheduler = None
        self._lock = threading.Lock()
        self._executor: Executor | None = None
        self._client: Any = None
        self._empty_since: float | None = None

    @property
    def kind(self) -> ExecutorKind:
        """``"dask"`` when sweeps go to a Dask cluster, else ``"processes"``."""
        return "dask" if self._scheduler is not None else "processes"

    def get(self) -> Executor:
        """Return the executor, starting the pool or connecting to Dask the first time.

        Raises
        ------
        ServiceUnavailableError
            The Dask scheduler does not answer, its cluster has no worker, or a worker
            cannot run this hydrodiag code or runs other code (:func:`_checked_workers`).
        """
        with self._lock:
            if self._client is not None and self._client.status not in ("running",
                                                                        "connecting"):
                # a scheduler away past the client's reconnect window closed the client
                # for good: every later sweep failed at once as "internal error" until a
                # restart (a Dask pass); connect again
                logger.warning("the Dask client to %s had closed; connecting again",
                               self._scheduler)
                self._client, self._executor = None, None
            if self._executor is None:
                if self._scheduler is not None:
                    self._client = _connected(self._scheduler, self._setting)
                    self._executor = self._client.get_executor()
                    self._empty_since = None
                else:
                    # each pool process ends itself once this process is gone: after a
                    # kill -9 of the service, the four sweep processes (~350 MB each) and
                    # their resource tracker lived on as orphans (an operator's pass)
                    self._executor = ProcessPoolExecutor(
                        max_workers=self._workers,
                        mp_context=multiprocessing.get_context("spawn"),
                        initializer=exit_with_parent, initargs=(os.getpid(),),
                    )
            return self._executor

    def check(self) -> None:
        """Raise when work sent to the Dask cluster cannot finish: its client closed, or no
        worker for :data:`NO_WORKER_S` (a sweep whose workers had all gone waited at 0 %
        for ever: a Dask pass).  Called while waiting for results; nothing for a local
        pool."""
        with self._lock:
            client = self._client
        if client is None:
            return
        if client.status not in ("running", "connecting"):
            raise ServiceUnavailableError(
                f"lost the Dask scheduler {self._scheduler} while the work ran; submit it "
                "again", field=self._setting)
        now = time.monotonic()
        try:
            threads = client.nthreads()
        except Exception:  # a scheduler that does not answer now: no worker to count
            threads = {}
        if threads:
            self._empty_since = None
        elif self._empty_since is None:
            self._empty_since = now
        elif now - self._empty_since > NO_WORKER_S:
            raise ServiceUnavailableError(
                f"the Dask cluster at {self._scheduler} has had no worker for "
                f"{NO_WORKER_S:g} s (do its workers have this hydrodiag installed?); "
                "submit the work again once workers run", field=self._setting)

    def waiting(self, progress: Any = None) -> Callable[[], None]:
        """What to call while results do not come: :meth:`check`, and a job's
        ``progress.check`` (a cancel asked of it) where it has one."""
        def look() -> None:
            self.check()
            check = getattr(progress, "check", None)
            if check is not None:
                check()

        return look

    def capacity(self) -> int:
        """Tasks the executor runs at once: the local pool's processes, or the threads of
        the Dask cluster's workers once connected (:func:`diagnostics.batch.
        executor_workers`, the batches' own rule)."""
        with self._lock:
            executor = self._executor
        return executor_workers(executor) if executor is not None else self._workers

    def state(self) -> ExecutorState:
        """Where the executor stands (:class:`ExecutorState`); connects to nothing.

        For a connected Dask client this asks the scheduler for its workers (a round trip:
        call it off the event loop, with a time limit); a scheduler set but not yet used
        stays ``idle`` — connecting checks every worker's code, work for a sweep.
        """
        if self._scheduler is None:
            return ExecutorState("processes", None, "local", self._workers, self._workers)
        with self._lock:
            client = self._client
        if client is None:
            return ExecutorState("dask", self._scheduler, "idle", None, None)
        status = str(client.status)
        if status == "connecting":
            return ExecutorState("dask", self._scheduler, "reconnecting", None, None)
        if status != "running":
            return ExecutorState("dask", self._scheduler, "closed", None, None)
        threads: dict[str, int] = client.nthreads()
        return ExecutorState("dask", self._scheduler, "connected", len(threads),
                             sum(threads.values()))

    def state_within(self, timeout: float) -> ExecutorState:
        """:meth:`state`, or ``not answering`` when the scheduler has not answered within
        ``timeout`` [s] (the question goes on in a daemon thread, ended by Dask's own
        time-outs; the caller does not wait for it).  Only a running client's state asks
        the scheduler: the others are answered here, without a thread."""
        with self._lock:
            client = self._client
        if client is None or str(client.status) != "running":
            return self.state()
        answer: list[ExecutorState] = []

        def ask() -> None:
            try:
                answer.append(self.state())
            except Exception:  # a scheduler failing the question: not answering either
                logger.debug("the Dask scheduler %s failed a state question",
                             self._scheduler, exc_info=True)

        asking = threading.Thread(target=ask, name="hydrodiag-executor-state", daemon=True)
        asking.start()
        asking.join(timeout)
        if answer:
            return answer[0]
        return ExecutorState(self.kind, self._scheduler, "not answering", None, None)

    def shutdown(self) -> None:
        """Stop the local pool or close the Dask client (a later :meth:`get` starts anew)."""
        with self._lock:
            executor, client = self._executor, self._client
            self._executor, self._client = None, None
        if client is not None:
            client.close()
        elif isinstance(executor, ProcessPoolExecutor):
            # the jobs were failed already: stop the processes rather than wait for the
            # points they compute (a SIGTERM with sweeps running took 11-13 s, past the
            # 10 s docker stop gives; an operator's pass)
            processes = list(getattr(executor, "_processes", {}).values())
            executor.shutdown(wait=False, cancel_futures=True)
            for p in processes:
                p.terminate()
            for p in processes:
                p.join(timeout=2.0)
