"""Where sweeps, batches and re-diagnoses run (app/services/executors.py) when the Dask
cluster is not what it should be (a Dask pass): an unreachable scheduler, a cluster without
a worker, workers on other code, a client the scheduler's absence closed, and results that
never come."""

from __future__ import annotations

import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import pytest

pytest.importorskip("distributed")

from distributed import LocalCluster

from app.errors import ServiceUnavailableError
from app.services import executors as module
from app.services.executors import SweepExecutors, _checked_workers
from diagnostics.batch import as_done


def _cluster(workers: int) -> LocalCluster:
    return LocalCluster(n_workers=workers, threads_per_worker=1, processes=False,
                        dashboard_address=None)


def test_an_unreachable_scheduler_is_a_503_naming_the_setting_within_seconds() -> None:
    """It was "internal error; see the service log" after Dask's 30 s, job after job."""
    executors = SweepExecutors(dask_scheduler="tcp://127.0.0.1:9")
    started = time.monotonic()
    with pytest.raises(ServiceUnavailableError) as refused:
        executors.get()
    assert time.monotonic() - started < 20.0
    assert refused.value.field == "HYDRODIAG_DASK_SCHEDULER"
    assert "tcp://127.0.0.1:9 does not answer" in refused.value.message


def test_a_cluster_without_a_worker_is_refused_and_one_with_a_worker_is_used() -> None:
    """Work sent to a cluster whose only worker died on its first task (no hydrodiag)
    waited at 0 % for ever; a cluster with no worker is refused at once."""
    with _cluster(0) as empty, pytest.raises(ServiceUnavailableError, match="has no worker"):
        SweepExecutors(dask_scheduler=empty.scheduler_address).get()
    with _cluster(1) as one:
        executors = SweepExecutors(dask_scheduler=one.scheduler_address)
        try:
            assert executors.get().submit(sum, [1, 2]).result(timeout=30) == 3
        finally:
            executors.shutdown()


class _Workers:
    """A client's two calls that :func:`_checked_workers` makes, answering as workers on
    other code or without hydrodiag would (a real cluster of other code is not at hand)."""

    def __init__(self, prints: dict[str, str] | Exception) -> None:
        self.prints = prints

    def nthreads(self) -> dict[str, int]:
        return {"tcp://10.0.0.7:4000": 1, "tcp://10.0.0.8:4000": 1}

    def run(self, function: Any) -> dict[str, str]:
        if isinstance(self.prints, Exception):
            raise self.prints
        return self.prints


def test_workers_on_other_code_or_without_hydrodiag_are_refused() -> None:
    """One worker on four-day-old code moved batch probabilities by up to 0.107 and 92 of
    200 sweep rows, without a word."""
    from app.services.code_version import code_fingerprint

    ours = code_fingerprint()
    assert len(ours) == 16 and code_fingerprint() == ours
    _checked_workers(_Workers({"tcp://10.0.0.7:4000": ours, "tcp://10.0.0.8:4000": ours}), "s")
    with pytest.raises(ServiceUnavailableError, match=r"1 of 2 workers .* other hydrodiag "
                       r"code .*10\.0\.0\.8"):
        _checked_workers(_Workers({"tcp://10.0.0.7:4000": ours,
                                   "tcp://10.0.0.8:4000": "0123456789abcdef"}), "s")
    with pytest.raises(ServiceUnavailableError, match="cannot run hydrodiag"):
        _checked_workers(_Workers(ModuleNotFoundError("No module named 'app'")), "s")


def test_a_closed_client_is_connected_again_and_lost_workers_end_the_wait(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A scheduler away past the client's reconnect window closed the client for good:
    every later sweep failed until a restart; and a cluster left without a worker is said
    after NO_WORKER_S, not waited on for ever."""
    monkeypatch.setattr(module, "NO_WORKER_S", 0.0)
    with _cluster(1) as cluster:
        executors = SweepExecutors(dask_scheduler=cluster.scheduler_address)
        try:
            executors.get()
            executors._client.close()   # as the client closes itself after 30 s away
            assert executors.get().submit(sum, [2, 2]).result(timeout=30) == 4
            executors.check()            # a worker: nothing to say
            cluster.scale(0)
            for _ in range(100):
                if not executors._client.nthreads():
                    break
                time.sleep(0.1)
            executors.check()            # the first look without a worker starts the clock
            with pytest.raises(ServiceUnavailableError, match="has had no worker"):
                executors.check()
        finally:
            executors.shutdown()


def test_waiting_is_called_while_nothing_completes_and_what_it_raises_ends_the_wait(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("diagnostics.batch.WAIT_S", 0.05)
    never = threading.Event()
    looks: list[float] = []

    def waiting() -> None:
        looks.append(time.monotonic())
        if len(looks) == 3:
            raise ServiceUnavailableError("gone")

    with ThreadPoolExecutor(2) as pool:
        quick: Future[int] = pool.submit(lambda: 1)
        stuck: Future[bool] = pool.submit(never.wait, 30)
        got = []
        with pytest.raises(ServiceUnavailableError):
            for future in as_done([quick, stuck], waiting):
                got.append(future.result())
        never.set()
    assert got == [1] and len(looks) == 3


def test_the_state_names_the_scheduler_and_its_workers_and_never_waits_long() -> None:
    """Nothing in /ready or /metrics named the scheduler or its reachability (a Dask
    pass): the state says the pool, an idle scheduler, a connected cluster's workers and
    threads, a closed client, and a question the scheduler does not answer in time."""
    local = SweepExecutors(workers=3)
    assert local.state() == module.ExecutorState("processes", None, "local", 3, 3)
    with _cluster(2) as cluster:
        executors = SweepExecutors(dask_scheduler=cluster.scheduler_address)
        try:
            idle = executors.state()
            assert (idle.kind, idle.scheduler, idle.connection) == (
                "dask", cluster.scheduler_address, "idle")
            executors.get()
            assert executors.state_within(10.0) == module.ExecutorState(
                "dask", cluster.scheduler_address, "connected", 2, 2)
            executors._client.close()
            assert executors.state().connection == "closed"
        finally:
            executors.shutdown()
    stuck = threading.Event()

    class _Stuck(SweepExecutors):
        def state(self) -> module.ExecutorState:
            stuck.wait(30.0)
            raise AssertionError("not waited for")

    slow = _Stuck(dask_scheduler="tcp://127.0.0.1:9")
    # a connected client (only a running client's state asks the scheduler)
    slow._client = type("Running", (), {"status": "running"})()
    started = time.monotonic()
    answer = slow.state_within(0.2)
    assert time.monotonic() - started < 5.0
    stuck.set()
    assert answer == module.ExecutorState("dask", "tcp://127.0.0.1:9", "not answering",
                                          None, None)
