"""The answer to ``POST /diagnose`` and its rows to store, from one encoding of each result.

A diagnosis's ``result`` (the full diagnosis: every hypothesis with its fits and
predictions, ~10-40 kB of JSON) is encoded once, with orjson (~20× faster than the standard
library's ``json`` on it), in the diagnosis process: the same bytes are the ``result`` of the
answer and the document of the stored row (with ``compact`` the answer's result, without
the predictions, is a second, smaller encoding).  They cross the pipe once: the row refers
to the same bytes object, which pickle writes once.

The answer is the JSON :class:`~app.schemas.diagnose.DiagnoseResponse` would serialise, its
fields in the schema's order; each diagnosis is a head (every field of
:class:`~app.schemas.diagnose.DiagnosisPublic` but ``result``, ``id`` null and no
measurement ids) and its result, joined when the answer is sent
(:meth:`DiagnoseAnswer.body`, which splices in the stored ids).
``tests/app/test_diagnosis_answer.py`` holds it equal to the pydantic serialisation.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import orjson

from app.schemas.diagnose import DisagreementPublic, EstimatePublic, GoodnessOfFitPublic
from app.schemas.times import iso_utc
from app.services.diagnosis import DiagnosisOutcome
from app.services.diagnosis_form import RecordForm, RequestForm, stored_document
from app.services.diagnosis_response import compact_result, time_notes

__all__ = ["UNSTORED_PREFIX", "DiagnoseAnswer", "StoredRows", "answer_of"]

#: How each diagnosis's head begins before it is stored (``id`` is its first field).
UNSTORED_PREFIX = b'{"id":null,"measurement_ids":[]'

_ESTIMATE_FIELDS = tuple(EstimatePublic.model_fields)
_FIT_FIELDS = tuple(GoodnessOfFitPublic.model_fields)
_DISAGREEMENT_FIELDS = tuple(DisagreementPublic.model_fields)


@dataclass(frozen=True, slots=True)
class StoredRows:
    """The rows of one diagnosis to store, JSON documents encoded.

    Attributes
    ----------
    rig_id, rig_version_id
        The rig and the row id of the version it was diagnosed with.
    measurements
        Each record's time [UTC] and its stored document (JSON, UTF-8), in request order.
    latest
        Index in ``measurements`` of the record that carries the diagnosis.
    component, probability
        What the diagnosis blames, and the probability of its top hypothesis [1].
    result
        The full result (JSON, UTF-8).
    estimates
        Per component: name, probability [1], clearance [m], slip coefficient [-], and
        the 95 % interval's low and high [m, or 1 for Cs].
    stated
        Whether the record carrying the diagnosis stated its ``measured_at`` (one that
        did not is stored at the request's time, and is no twin of a stored one).
    path
        Where that record is in the request (``record``, ``records[3]``): a conflict
        names it.
    """

    rig_id: int
    rig_version_id: int
    measurements: list[tuple[datetime, bytes]]
    latest: int
    component: str
    probability: float
    result: bytes
    estimates: list[tuple[str, float | None, float | None, float | None, float | None,
                          float | None]]
    stated: bool = True
    path: str = "record"


@dataclass(frozen=True, slots=True)
class DiagnoseAnswer:
    """The answer of a task: JSON parts, and the rows to store (empty when not stored).

    Attributes
    ----------
    head
        ``{"mode":...,"stored":...,"compact":...,"diagnoses":[`` (JSON, UTF-8).
    diagnoses
        Each diagnosis as its head (up to ``"result":``, ``id`` null and no measurement
        ids) and its result (JSON, UTF-8).
    rows
        The rows of each diagnosis, when the request stores them.
    """

    head: bytes
    diagnoses: list[tuple[bytes, bytes]]
    rows: list[StoredRows]

    def body(self, ids: list[tuple[int, list[int]]] | None = None) -> bytes:
        """The answer's JSON, with each diagnosis's stored id and measurement ids."""
        if ids is not None and len(ids) != len(self.diagnoses):
            raise ValueError("one pair of stored ids per diagnosis is needed")
        parts = [self.head]
        for i, (head, result) in enumerate(self.diagnoses):
            if i:
                parts.append(b",")
            if ids is not None:
                diagnosis_id, measurement_ids = ids[i]
                assert head.startswith(UNSTORED_PREFIX)
                listed = ",".join(str(m) for m in measurement_ids)
                parts.append(f'{{"id":{diagnosis_id},"measurement_ids":[{listed}]'.encode())
                parts.append(head[len(UNSTORED_PREFIX):])
            else:
                parts.append(head)
            parts.append(result)
            parts.append(b"}")
        parts.append(b"]}")
        return b"".join(parts)




def _fit_public(fit: Any) -> Any:
    """The result's goodness-of-fit test with the fields of its public schema."""
    if not isinstance(fit, Mapping):
        return fit
    public = {name: fit.get(name) for name in _FIT_FIELDS}
    public["disagreements"] = [{name: d.get(name) for name in _DISAGREEMENT_FIELDS}
                               for d in fit.get("disagreements") or []]
    return public


def _head(outcome: DiagnosisOutcome) -> bytes:
    """The diagnosis's fields but ``result``, as JSON up to ``"result":``."""
    result = outcome.result
    public = {
        "id": None, "measurement_ids": [], "records": outcome.paths,
        "rig_id": outcome.resolved.rig_id, "rig_version": outcome.resolved.version,
        "measured_at": iso_utc(outcome.measured_at.astimezone(UTC)), "top": outcome.top,
        "component": outcome.component, "probability": outcome.probability,
        "explained": result.get("explained", True),
        "goodness_of_fit": _fit_public(result.get("goodness_of_fit")),
        "misfit": result.get("misfit"), "regime_notes": result.get("regime_notes", []),
        "estimates": [{name: getattr(e, name) for name in _ESTIMATE_FIELDS}
                      for e in outcome.estimates],
    }
    encoded = orjson.dumps(public, option=orjson.OPT_SERIALIZE_NUMPY)
    assert encoded.startswith(UNSTORED_PREFIX) and encoded.endswith(b"}")
    return encoded[:-1] + b',"result":'


def _rows(outcome: DiagnosisOutcome, records: Mapping[str, RecordForm], now: datetime,
          result: bytes) -> StoredRows:
    # a joint result belongs to the latest record; the others are kept beside it
    times = [records[p].measured_at or now for p in outcome.paths]
    latest = max(range(len(times)), key=lambda i: (times[i], i))
    stored = [(t, orjson.dumps(stored_document(records[p], t)))
              for p, t in zip(outcome.paths, times, strict=True)]
    estimates = [(h.component, h.probability, h.clearance_m, h.slip_coefficient, h.low, h.high)
                 for h in (e.history() for e in outcome.estimates)]
    return StoredRows(outcome.resolved.rig_id, outcome.resolved.version_id, stored, latest,
                      outcome.component, outcome.probability, result, estimates,
                      records[outcome.paths[latest]].measured_at is not None,
                      outcome.paths[latest])


def answer_of(form: RequestForm, outcomes: list[DiagnosisOutcome], now: datetime
              ) -> DiagnoseAnswer:
    """The answer to the request of ``form`` from its outcomes, with the rows to store.

    ``now`` is the time of the request (that of records without one) [UTC].
    """
    head = orjson.dumps({"mode": form.mode, "stored": form.store, "compact": form.compact,
                         "notes": time_notes(
                             [r.path for r in form.records if r.measured_at is None],
                             form.store, now), "diagnoses": []})
    assert head.endswith(b"[]}")
    records = {r.path: r for r in form.records}
    diagnoses, rows = [], []
    for outcome in outcomes:
        full = orjson.dumps(outcome.result)
        sent = orjson.dumps(compact_result(outcome.result)) if form.compact else full
        diagnoses.append((_head(outcome), sent))
        if form.store:
            rows.append(_rows(outcome, records, now, full))
    return DiagnoseAnswer(head[:-2], diagnoses, rows)
