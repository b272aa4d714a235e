"""A whole ``POST /diagnose`` as one task for a diagnosis process: body bytes in, answer out.

The server process of ``POST /diagnose`` is a thin pipe (issue 9): it validates the body
(FastAPI, so that a malformed request is the same 422 as ever), checks the key, and hands
the body's bytes to a diagnosis process as a :class:`DiagnoseTask`.  There
:func:`run_task` resolves the rigs against the store (a session of that process's own),
builds the records, diagnoses them, serialises each answer's JSON and prepares the rows to
store with their JSON documents already serialised (:class:`StoredRows`).  It answers with
a :class:`DiagnoseAnswer` (or a :class:`TaskFailure` that names the field), plain data that
pickles quickly; the server stores the rows (:func:`app.services.diagnosis_rows.insert_rows`,
SQLAlchemy Core) and splices the stored ids into the answer's bytes
(:meth:`DiagnoseAnswer.body`).  Nothing of the diagnosis or its JSON runs in the server
process.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from datetime import datetime
from typing import Literal

from app.db.engine import SessionFactory
from app.schemas.diagnose import DiagnoseRequest, DiagnoseResponse, DiagnosisPublic
from app.services.diagnosis import (
    DiagnosisOutcome,
    GroupPlan,
    GroupResult,
    compute_group,
    outcome_of,
    plan_groups,
    request_error,
    response_of,
)
from app.services.measurements import stored_record
from app.services.rig_cache import RigCache
from sim.errors import HydrodiagError, InputError

__all__ = ["DiagnoseAnswer", "DiagnoseTask", "StoredRows", "TaskFailure", "run_task"]

#: How each serialised diagnosis begins before it is stored (``id`` is its first field).
UNSTORED_PREFIX = b'{"id":null,"measurement_ids":[]'


@dataclass(frozen=True, slots=True)
class DiagnoseTask:
    """One ``POST /diagnose`` for a diagnosis process.

    Attributes
    ----------
    body
        The request body as received (validated by the server already).
    now
        Time of the request [UTC]: that of records without one.
    """

    body: bytes
    now: datetime


@dataclass(frozen=True, slots=True)
class StoredRows:
    """The rows of one diagnosis to store, JSON documents serialised.

    Attributes
    ----------
    rig_id, rig_version_id
        The rig and the row id of the version it was diagnosed with.
    measurements
        Each record's time [UTC] and its stored document (JSON text), in request order.
    latest
        Index in ``measurements`` of the record that carries the diagnosis.
    component, probability
        What the diagnosis blames, and the probability of its top hypothesis [1].
    result
        The full result (JSON text).
    estimates
        Per component: name, probability [1], clearance [m], slip coefficient [-].
    """

    rig_id: int
    rig_version_id: int
    measurements: list[tuple[datetime, str]]
    latest: int
    component: str
    probability: float
    result: str
    estimates: list[tuple[str, float | None, float | None, float | None]]


@dataclass(frozen=True, slots=True)
class DiagnoseAnswer:
    """The answer of a task: JSON parts, and the rows to store (empty when not stored).

    Attributes
    ----------
    head
        ``{"mode":...,"stored":...,"compact":...,"diagnoses":[`` as bytes.
    diagnoses
        Each diagnosis serialised, with ``id`` null and no measurement ids.
    rows
        The rows of each diagnosis, when the request stores them.
    """

    head: bytes
    diagnoses: list[bytes]
    rows: list[StoredRows]

    def body(self, ids: list[tuple[int, list[int]]] | None = None) -> bytes:
        """The answer's JSON, with each diagnosis's stored id and measurement ids."""
        parts = self.diagnoses
        if ids is not None:
            parts = []
            for part, (diagnosis_id, measurement_ids) in zip(self.diagnoses, ids, strict=True):
                assert part.startswith(UNSTORED_PREFIX)
                listed = ",".join(str(i) for i in measurement_ids)
                stored = f'{{"id":{diagnosis_id},"measurement_ids":[{listed}]'
                parts.append(stored.encode() + part[len(UNSTORED_PREFIX):])
        return self.head + b",".join(parts) + b"]}"


@dataclass(frozen=True, slots=True)
class TaskFailure:
    """An error of the library, carried back as plain data (its ``field`` survives)."""

    kind: type[HydrodiagError]
    message: str
    field: str | None

    def error(self) -> HydrodiagError:
        """The error to raise in the server process."""
        return self.kind(self.message, field=self.field)


def _rows(outcome: DiagnosisOutcome, request: DiagnoseRequest, now: datetime) -> StoredRows:
    records = dict(request.items())
    # a joint result belongs to the latest record; the others are kept beside it
    times = [records[p].measured_at or now for p in outcome.paths]
    latest = max(range(len(times)), key=lambda i: (times[i], i))
    stored = [(t, json.dumps(stored_record(records[p], t)))
              for p, t in zip(outcome.paths, times, strict=True)]
    estimates = [(h.component, h.probability, h.clearance_m, h.slip_coefficient)
                 for h in (e.history() for e in outcome.estimates)]
    return StoredRows(outcome.resolved.rig_id, outcome.resolved.version_id, stored, latest,
                      outcome.component, outcome.probability, json.dumps(outcome.result),
                      estimates)


def answer_of(request: DiagnoseRequest, outcomes: list[DiagnosisOutcome], now: datetime
              ) -> DiagnoseAnswer:
    """The answer to ``request`` from its outcomes: serialised, with the rows to store."""
    response = response_of(request, outcomes)
    mode: Literal["single", "each", "joint"] = response.mode
    head = DiagnoseResponse(mode=mode, stored=response.stored, compact=response.compact,
                            diagnoses=[]).model_dump_json().encode()
    assert head.endswith(b"[]}")
    parts = [DiagnosisPublic.model_dump_json(d).encode() for d in response.diagnoses]
    rows = [_rows(o, request, now) for o in outcomes] if request.store else []
    return DiagnoseAnswer(head[:-2], parts, rows)


def run_task(sessions: SessionFactory, rigs: RigCache, task: DiagnoseTask
             ) -> DiagnoseAnswer | TaskFailure:
    """Resolve, diagnose and serialise the request of ``task`` (in a diagnosis process).

    Parameters
    ----------
    sessions
        Session factory of the store (to resolve the rigs; nothing is written).
    rigs
        The process's compiled rigs.
    task
        The request.

    Returns
    -------
    DiagnoseAnswer or TaskFailure
        The answer; or the error (unknown rig or version, a record impossible on its rig),
        its ``field`` a path in the request.
    """
    try:
        request = DiagnoseRequest.model_validate(json.loads(task.body))
        with sessions() as session:
            plans = plan_groups(session, rigs, request, task.now)
        outcomes = [outcome_of(plan, _computed(plan)) for plan in plans]
        return answer_of(request, outcomes, task.now)
    except HydrodiagError as exc:
        return TaskFailure(type(exc), exc.message, exc.field)


def _computed(plan: GroupPlan) -> GroupResult:
    try:
        return compute_group(plan.resolved.rig, plan.records, plan.resolved.version)
    except InputError as exc:
        raise request_error(exc, plan) from None
