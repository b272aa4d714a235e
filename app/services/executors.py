"""Where sweeps run: a :class:`concurrent.futures.Executor`, local or on a Dask cluster.

Sweeps only use ``executor.submit(fn, *args)`` and :func:`concurrent.futures.as_completed`,
so one code path serves both kinds:

* **local** (default) — a :class:`~concurrent.futures.ProcessPoolExecutor` of
  ``HYDRODIAG_SWEEP_WORKERS`` processes (default: one per core), started with ``spawn``
  (the service has threads; forking them is unsafe) on the first sweep and kept for the
  next ones, so the import of :mod:`sim` is paid once per worker;
* **Dask** — when ``HYDRODIAG_DASK_SCHEDULER`` names a scheduler (``tcp://host:8786``) and
  ``dask.distributed`` is importable, a :class:`distributed.Client` connects to it and its
  ``get_executor()`` is used: a genuine ``concurrent.futures.Executor`` whose futures work
  with ``as_completed``.  The workers need hydrodiag installed (they import
  :mod:`app.services.sweep_worker`, which loads only ``sim``).  Without the package the
  setting is ignored with a warning and the local pool is used.
"""

from __future__ import annotations

import importlib.util
import logging
import multiprocessing
import os
import threading
from concurrent.futures import Executor, ProcessPoolExecutor
from typing import Any, Literal

from app.lifeline import exit_with_parent

__all__ = ["ExecutorKind", "SweepExecutors", "dask_available"]

logger = logging.getLogger("hydrodiag.app")

ExecutorKind = Literal["processes", "dask"]


def dask_available() -> bool:
    """Whether ``dask.distributed`` can be imported here."""
    return importlib.util.find_spec("distributed") is not None


class SweepExecutors:
    """Hands out the executor of the sweeps, created on first use and kept.

    Parameters
    ----------
    workers
        Processes of the local pool; ``None``: one per core.
    dask_scheduler
        Address of a Dask scheduler; ``None`` for the local pool.
    """

    def __init__(self, *, workers: int | None = None, dask_scheduler: str | None = None) -> None:
        self._workers = workers or os.cpu_count() or 1
        self._scheduler = dask_scheduler if dask_scheduler else None
        if self._scheduler is not None and not dask_available():
            logger.warning("HYDRODIAG_DASK_SCHEDULER is set but dask.distributed is not "
                           "installed; sweeps run on local processes")
            self._scheduler = None
        self._lock = threading.Lock()
        self._executor: Executor | None = None
        self._client: Any = None

    @property
    def kind(self) -> ExecutorKind:
        """``"dask"`` when sweeps go to a Dask cluster, else ``"processes"``."""
        return "dask" if self._scheduler is not None else "processes"

    def get(self) -> Executor:
        """Return the executor, starting the pool or connecting to Dask the first time."""
        with self._lock:
            if self._executor is None:
                if self._scheduler is not None:
                    from distributed import Client

                    self._client = Client(self._scheduler)
                    self._executor = self._client.get_executor()
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

    def capacity(self) -> int:
        """Tasks the executor runs at once: the local pool's processes, or the threads of
        the Dask cluster's workers (:meth:`distributed.Client.nthreads`) once connected."""
        with self._lock:
            client = self._client
        if client is not None:
            return max(1, sum(client.nthreads().values()))
        return self._workers

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
