"""Batches of records (diagnostics/batch.py): a chunk the executor loses costs its own
records only, and a Dask executor's chunks are planned for its cluster."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from typing import Any

from diagnostics.batch import diagnose_many, executor_workers
from sim.rigs import reference_rig
from tests.diagnostics.synth import record


class _LosesSecondChunk(Executor):
    """Threads that run every chunk but the second, whose future fails as a lost Dask
    task's does (a real pool; the loss is the one thing made up)."""

    def __init__(self) -> None:
        self._pool = ThreadPoolExecutor(2)
        self._n = 0

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        self._n += 1
        if self._n == 2:
            lost: Future[Any] = Future()
            lost.set_exception(OSError("the scheduler went away"))
            return lost
        return self._pool.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, **kwargs: Any) -> None:
        self._pool.shutdown(wait=wait)


def test_a_lost_chunk_is_an_error_line_for_its_records_and_the_rest_are_kept() -> None:
    """A batch whose Dask scheduler died threw every finished record away with a bare
    CancelledError (a Dask pass)."""
    rig = reference_rig()
    records = [record(rig, {"valve.cv": 60e-6}, load=1500.0 + 300 * k) for k in range(6)]
    here = diagnose_many(rig, records)
    executor = _LosesSecondChunk()
    try:
        out = diagnose_many(rig, records, executor=executor, chunk_size=2)
    finally:
        executor.shutdown()
    lost = [r for r in out if "error" in r]
    assert [i for i, r in enumerate(out) if "error" in r] == [2, 3]
    assert all("the executor lost its chunk (OSError: the scheduler went away)"
               in r["error"]["message"] for r in lost)
    for k in (0, 1, 4, 5):
        assert out[k]["top"] == here[k]["top"]
        assert abs(out[k]["probability"] - here[k]["probability"]) < 1e-9


def test_chunks_are_planned_for_the_executors_workers() -> None:
    """A Dask executor's chunks were planned for 2 workers whatever its cluster (a Dask
    pass): its cluster's threads are counted."""
    import pytest

    with ThreadPoolExecutor(3) as pool:
        assert executor_workers(pool) == 3
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=3, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        assert executor_workers(client.get_executor()) == 3
