"""The diagnosis process: its main loop, reading tasks from its pipe to the server process.

Started by :class:`app.services.diagnosis_pool.DiagnosisPool` (``spawn``).  It compiles and
warms the rigs it is given (:func:`warm_rig`), runs one whole unstored request of the first
through the store (:func:`warm_task`: its first real request then costs what any other
does, not ~0.9 s of first calls), says ``("ready", pid)`` on its pipe, then answers one
message at a time, each a pickled ``(kind, payload)``:

``("request", DiagnoseTask)``
    A whole ``POST /diagnose`` (:func:`app.services.diagnosis_task.run_task`): the rigs are
    resolved against the store through a session of this process's own.
``("group", (key, document, records))``
    One planned group (the console's path): the rig by its key, compiled from ``document``
    on a miss, or the answer :data:`MISSING` when the document was not sent.
``("pid", None)``
    The process id (tests).

Each answer is a pickled ``(seconds, result)``: the time the task took here [s] (the pool's
admission control learns the service time from it) and its result or a
:class:`~app.services.diagnosis_task.TaskFailure`.  The process leaves when its pipe
closes or its parent is gone, even after a ``kill -9`` of the parent.
"""

from __future__ import annotations

import contextlib
import logging
import os
import pickle
import signal
import time
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from multiprocessing.connection import Connection
from typing import Any

from sqlalchemy.engine import make_url

from app.db.engine import SessionFactory, make_engine, make_session_factory
from app.lifeline import exit_with_parent
from app.services.diagnosis import compute_group
from app.services.diagnosis_form import RecordForm, RequestForm
from app.services.diagnosis_task import DiagnoseTask, TaskFailure, run_task
from app.services.rig_cache import RigCache, RigKey
from app.services.warmup import settle_heap
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from sim.errors import HydrodiagError
from sim.rigs import Rig
from sim.steady import steady_cycle

__all__ = ["MISSING", "serve_pipe", "warm_rig", "warm_task"]

logger = logging.getLogger("hydrodiag.app")

#: The answer of a worker that lacks the rig and was not sent its document.
MISSING = "rig document needed"


def _warm_readings(rig: Rig) -> tuple[dict[str, float], dict[str, float]] | None:
    """The condition and the readings a healthy ``rig`` gives at its default condition
    (every reading the reference bench logs, and the velocity ratio), or ``None`` when the
    piston stalls there (nothing to diagnose)."""
    condition = rig.default_condition()
    cycle = steady_cycle(rig, condition=condition)
    if not cycle.velocity_ratio > 0:
        return None
    load = ({"back_pressure": condition.back_pressure} if condition.back_pressure
            else {"load_force": condition.load})
    work, back = cycle.working.values, cycle.return_.values
    readings = {"pump_pressure": work["P_pump"], "p1": work["P1"], "p2": work["P2"],
                "flow_B": work["Q_meter_B"], "flow_C": work["Q_meter_C"],
                "speed_work": work["speed"], "speed_return": back["speed"]}
    return {"oil_temperature": condition.oil_temperature} | load, readings


def warm_rig(rig: Rig) -> None:
    """Call the compiled code a diagnosis uses once on ``rig``: a steady cycle at the
    rig's default condition, then a diagnosis of the velocity ratio it predicts and one of
    all the readings it predicts (single and pair fits, goodness of fit, direct
    inversions)."""
    warm = _warm_readings(rig)
    if warm is None:
        return
    condition, readings = warm
    ratio = readings["speed_work"] / readings["speed_return"]
    for values in ({"velocity_ratio": ratio}, readings):
        record = MeasurementRecord.from_readings(
            "warm-up", OperatingCondition.from_readings(condition), values,
            rig_name="warm-up", taken_at=datetime.now(UTC))
        with contextlib.suppress(HydrodiagError):  # a rig whose readings the maps refuse
            compute_group(rig, [record], 1)


def warm_task(key: RigKey, rig: Rig) -> DiagnoseTask | None:
    """A whole unstored ``POST /diagnose`` of ``rig``'s healthy readings at its default
    condition (:func:`_warm_readings`), to run once through the store before the first
    request: the store's engine and statements, the records, the diagnosis and the answer's
    encoding.  ``None`` when the piston stalls at that condition."""
    warm = _warm_readings(rig)
    if warm is None:
        return None
    condition, readings = warm
    record = RecordForm("record", key[0], key[1], None, None,
                        {k: (v, None, None) for k, v in condition.items()},
                        {k: (v, None, None) for k, v in readings.items()})
    return DiagnoseTask(RequestForm("single", False, False, [record]), datetime.now(UTC))


class _Worker:
    """What one diagnosis process keeps: its compiled rigs and, on first need, a session
    factory of the store."""

    def __init__(self, url: str | None, cache_size: int) -> None:
        self.url = url
        self.rigs = RigCache(cache_size)
        self._sessions: SessionFactory | None = None

    def sessions(self) -> SessionFactory:
        if self._sessions is None:
            if self.url is None:
                raise HydrodiagError("this diagnosis process has no store to read rigs from")
            self._sessions = make_session_factory(make_engine(make_url(self.url)))
        return self._sessions

    def group(self, key: RigKey, document: Mapping[str, Any] | None,
              records: list[MeasurementRecord]) -> Any:
        rig = self.rigs.compiled(key, document)
        if rig is None:
            return MISSING
        return compute_group(rig, records, key[1])

    def handle(self, kind: str, payload: Any) -> Any:
        try:
            if kind == "request":
                return run_task(self.sessions(), self.rigs, payload)
            if kind == "group":
                return self.group(*payload)
            if kind == "pid":
                return os.getpid()
            raise ValueError(f"unknown task kind {kind!r}")
        except HydrodiagError as exc:
            return TaskFailure.of(exc)
        except Exception as exc:  # never leave the server waiting for an answer
            logger.exception("a diagnosis task failed")
            return TaskFailure(HydrodiagError, f"internal error in a diagnosis process: "
                               f"{type(exc).__name__}", None)


def serve_pipe(connection: Connection, url: str | None, cache_size: int, parent: int,
               rigs: Sequence[tuple[RigKey, Mapping[str, Any]]]) -> None:
    """Main function of a diagnosis process: warm ``rigs``, then answer tasks until the
    pipe closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C stops the server, which stops us
    exit_with_parent(parent)
    worker = _Worker(url, cache_size)
    for key, document in rigs:
        try:
            rig = worker.rigs.compiled(key, document)
            assert rig is not None  # compiled from its document
            warm_rig(rig)
        except HydrodiagError as exc:  # a rig that cannot run still answers 422s
            logger.warning("rig %s not warmed in a diagnosis process: %s", key[0], exc)
    for key, _ in rigs[:1]:  # once through the store and the answer: the first request
        rig = worker.rigs.compiled(key, None)  # then costs what any other does
        task = None if rig is None or url is None else warm_task(key, rig)
        if task is not None and isinstance(worker.handle("request", task), TaskFailure):
            logger.warning("the warm-up request of rig %s failed", key[0])
    settle_heap()   # the warm heap out of the collector's sight (app.services.warmup)
    try:
        connection.send_bytes(pickle.dumps(("ready", os.getpid())))
    except (EOFError, OSError):  # the server stopped while this process warmed: every
        return                   # stop logged a BrokenPipeError traceback (an operator pass)
    while True:
        try:
            message = connection.recv_bytes()
        except (EOFError, OSError):
            return
        start = time.perf_counter()
        kind, payload = pickle.loads(message)
        result = worker.handle(kind, payload)
        answer = pickle.dumps((time.perf_counter() - start, result),
                              protocol=pickle.HIGHEST_PROTOCOL)
        try:
            connection.send_bytes(answer)
        except (EOFError, OSError):
            return
