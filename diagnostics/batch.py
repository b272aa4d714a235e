"""Diagnose many records, each on its own, in-process or on any executor (issue 9).

``diagnose_many(rig, records)`` runs every record through :func:`diagnostics.diagnose.diagnose`
(the compiled fast path by default) and returns one plain result per record, in order.
With ``executor`` (a :class:`concurrent.futures.Executor`: a process pool, or the
``get_executor()`` of a Dask ``distributed.Client`` — the executors sweeps use,
:class:`app.services.executors.SweepExecutors`) the records go out in chunks together with
the rig *document*; a worker compiles each rig once (the numba cache makes that a load,
not a compile) and keeps it, so continuation states and signature maps carry over from one
chunk to the next.  A record the rig cannot take (no operating point, an impossible
reading) gives an ``error`` entry and does not stop the batch.

This module imports only :mod:`diagnostics` and :mod:`sim`: a worker loads no service code.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import Executor, Future, as_completed
from typing import Any, TypeVar

from diagnostics.diagnose import Diagnosis, diagnose
from diagnostics.measurement import MeasurementRecord
from diagnostics.ranking import Method
from sim.errors import HydrodiagError
from sim.rigs import Rig
from sim.rigs.process_cache import rig_of_document

__all__ = ["WAIT_S", "as_done", "diagnose_chunk", "diagnose_many", "executor_workers", "summary"]

#: how often :func:`as_done` calls its ``waiting`` while no future completes [s]
WAIT_S = 1.0

_T = TypeVar("_T")


def executor_workers(executor: Executor) -> int:
    """Tasks ``executor`` runs at once: a standard library pool's workers, a Dask
    executor's cluster threads (it planned for 2 whatever the cluster: a Dask pass), else
    2."""
    pool = int(getattr(executor, "_max_workers", 0) or 0)
    if pool:
        return pool
    client = getattr(executor, "_client", None)   # distributed's ClientExecutor
    try:
        threads = sum(client.nthreads().values()) if client is not None else 0
    except Exception:  # a client that cannot say: the default below
        threads = 0
    return int(threads) or 2


def _lost(exc: BaseException) -> dict[str, Any]:
    """The error line of a record whose chunk the executor lost."""
    return {"error": {"type": "HydrodiagError", "field": None,
                      "message": f"not diagnosed: the executor lost its chunk "
                                 f"({type(exc).__name__}: {exc})"[:300]}}


def as_done(futures: Iterable[Future[_T]], waiting: Callable[[], None] | None = None
            ) -> Iterator[Future[_T]]:
    """The futures as they complete (:func:`concurrent.futures.as_completed`), calling
    ``waiting`` about every :data:`WAIT_S` until all have: a cancel asked of a job, or a
    Dask cluster left without a worker, raises there.  A sweep whose workers had all gone
    waited at 0 % for ever, and its cancel did nothing (a Dask pass).  One
    ``as_completed`` a period over those still pending (a ``wait`` after each completion
    cost O(pending) each time: 8,000 small tasks on 2 threads took 13.7 s, 1.2 s so)."""
    pending = set(futures)
    while pending:
        try:
            for future in as_completed(pending, timeout=WAIT_S):
                pending.discard(future)
                yield future
        except TimeoutError:
            if waiting is not None:
                waiting()

#: progress callback: (records done, records in all)
Progress = Callable[[int, int], None]


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def summary(d: Diagnosis) -> dict[str, Any]:
    """The compact result of one diagnosis: the named fault (``"unexplained"`` when the
    goodness-of-fit test fails), its probability (0 when unexplained, as ``POST /diagnose``
    states it: a batch line read "unexplained" with probability 1.0), the best fit and its
    probability and estimates [SI], the χ² p-value, the factor on the uncertainties at which
    the tested fit would pass (:attr:`~diagnostics.goodness_result.GoodnessOfFit.
    uncertainty_factor`) and the probabilities of all observable hypotheses."""
    top = d.top
    return {
        "top": top.name if d.explained else "unexplained",
        "probability": top.probability if d.explained else 0.0,
        "best_fit": top.name,
        "best_fit_probability": top.probability,
        "explained": d.explained,
        "p_value": None if d.fit is None else d.fit.p_value,
        "uncertainty_factor": None if d.fit is None else d.fit.uncertainty_factor,
        "parameters": [{"name": p.name, "unit": p.unit, "value": p.value, "low": p.low,
                        "high": p.high, "severity": p.severity} for p in top.parameters],
        "probabilities": {f.name: f.probability for f in d.hypotheses if f.observable},
        "chi2": _finite(top.chi2),
    }


def _one(rig: Rig, record: MeasurementRecord, full: bool, method: Method | None
         ) -> dict[str, Any]:
    try:
        d = diagnose(rig, [record], method=method)
    except HydrodiagError as exc:  # the shape of a record refused before it ran
        return {"error": {"type": type(exc).__name__, "field": exc.field,
                          "message": exc.message}}
    return d.to_dict() if full else summary(d)


def diagnose_chunk(document: Mapping[str, Any], records: Sequence[MeasurementRecord],
                   full: bool = False, method: Method | None = None) -> list[dict[str, Any]]:
    """Diagnose each of ``records`` on the rig of ``document`` (what a worker runs).

    Returns
    -------
    list of dict
        Per record :func:`summary` (``full``: :meth:`Diagnosis.to_dict`), or
        ``{"error": {"type": ..., "field": ..., "message": ...}}``.
    """
    rig = rig_of_document(document)
    return [_one(rig, r, full, method) for r in records]


def diagnose_many(rig: Rig, records: Sequence[MeasurementRecord], *,
                  executor: Executor | None = None, progress: Progress | None = None,
                  chunk_size: int | None = None, full: bool = False,
                  method: Method | None = None, workers: int | None = None,
                  waiting: Callable[[], None] | None = None) -> list[dict[str, Any]]:
    """Diagnose each record on its own; results in the order of ``records`` (a record the
    executor lost with its chunk — a Dask scheduler gone, a pool process killed — is an
    error line saying so, the others kept).

    Parameters
    ----------
    rig
        The rig (with an executor its document, :meth:`RigSpec.to_document`, travels).
    records
        The records.
    executor
        Where to run: None in this process; else chunks are submitted to it.
    progress
        Called with (done, total) after each record (in-process) or chunk.
    chunk_size
        Records per submitted task (default: about 8 tasks per worker, at most 250).
    workers
        Workers behind ``executor``, for the default chunk size; default that of a
        standard library pool, a Dask executor's cluster threads, else 2.
    full
        Whole :meth:`Diagnosis.to_dict` results instead of :func:`summary`.
    method
        ``"fast"`` (default) or ``"direct"`` (:class:`~diagnostics.ranking.Ranker`).
    waiting
        With an executor, called every second while no chunk completes; what it raises
        ends the wait (:func:`as_done`).
    """
    total = len(records)
    if executor is None:
        out = []
        for i, r in enumerate(records):
            out.append(_one(rig, r, full, method))
            if progress is not None:
                progress(i + 1, total)
        return out
    if workers is None:
        workers = executor_workers(executor)
    size = chunk_size or max(1, min(250, math.ceil(total / (8 * workers))))
    document = rig.spec.to_document()
    futures: dict[Future[list[dict[str, Any]]], int] = {}
    futures_records: dict[Future[list[dict[str, Any]]], list[MeasurementRecord]] = {}
    for start in range(0, total, size):
        chunk_records = list(records[start:start + size])
        fut = executor.submit(diagnose_chunk, document, chunk_records, full, method)
        futures[fut] = start
        futures_records[fut] = chunk_records
    results: list[dict[str, Any] | None] = [None] * total
    done = 0
    for fut in as_done(futures, waiting):
        start = futures[fut]
        try:
            chunk = fut.result()
        except (Exception, asyncio.CancelledError) as exc:
            # a chunk the executor lost (a Dask scheduler gone, a pool process killed) is
            # an error line for each of its records, the others kept: a batch whose
            # scheduler died threw every finished record away (a Dask pass)
            chunk = [_lost(exc)] * len(futures_records[fut])
        results[start:start + len(chunk)] = chunk
        done += len(chunk)
        if progress is not None:
            progress(done, total)
    return [r if r is not None else {"error": {"type": "HydrodiagError", "field": None,
                                               "message": "lost"}} for r in results]
