"""The answer of ``POST /diagnose`` (and ``hydrodiag diagnose``) from its diagnoses: each
diagnosis as the API shows it, the request's notes, the compact form.

Split from :mod:`app.services.diagnosis` (diagnosing and storing) as its own concern (a
code review: the module held both at 578 lines).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from datetime import UTC, datetime
from typing import Any, Literal

from app.schemas.diagnose import (
    DiagnoseRequest,
    DiagnoseResponse,
    DiagnosisPublic,
    EstimatePublic,
)
from app.schemas.times import iso_utc
from app.services.diagnosis import DiagnosisOutcome

__all__ = ["compact_result", "response_json", "response_of", "time_notes"]


def compact_result(result: dict[str, Any]) -> dict[str, Any]:
    """``result`` without each hypothesis's predicted readings (the bulk of its size)."""
    hypotheses = [{k: v for k, v in h.items() if k != "predicted"}
                  for h in result.get("hypotheses", [])]
    return result | {"hypotheses": hypotheses}


def _public(outcome: DiagnosisOutcome, compact: bool) -> DiagnosisPublic:
    return DiagnosisPublic(
        id=outcome.diagnosis_id,
        measurement_ids=outcome.measurement_ids,
        records=outcome.paths,
        rig_id=outcome.resolved.rig_id,
        rig_version=outcome.resolved.version,
        measured_at=outcome.measured_at.astimezone(UTC),  # as GET /diagnoses reads it back
        top=outcome.top,
        component=outcome.component,
        probability=outcome.probability,
        estimates=[EstimatePublic.model_validate(asdict(e)) for e in outcome.estimates],
        result=compact_result(outcome.result) if compact else outcome.result,
        explained=outcome.result.get("explained", True),
        goodness_of_fit=outcome.result.get("goodness_of_fit"),
        misfit=outcome.result.get("misfit"),
        regime_notes=outcome.result.get("regime_notes", []),
    )


def time_notes(untimed: Sequence[str], store: bool, now: datetime) -> list[str]:
    """A note naming the stored records that state no ``measured_at`` (``untimed``, their
    paths): they are kept at the request's time ``now`` [UTC], where the history and trends
    place them (a fleet pass back-filling logs without times got a wrong time axis without
    a word)."""
    if not store or not untimed:
        return []
    named = ", ".join(untimed[:5]) + (f" and {len(untimed) - 5} more" if len(untimed) > 5
                                      else "")
    verb = "state" if len(untimed) > 1 else "states"
    return [f"{named} {verb} no measured_at: stored at the time of this request "
            f"({iso_utc(now.astimezone(UTC))}), where the history and trends place "
            f"{'them' if len(untimed) > 1 else 'it'}; send the time the readings were taken "
            "(measured_at, ISO 8601) with logged data"]


def response_of(request: DiagnoseRequest, outcomes: Sequence[DiagnosisOutcome],
                now: datetime) -> DiagnoseResponse:
    """The answer to ``request`` (the body of ``POST /diagnose``) made at ``now`` [UTC];
    with ``compact``, each ``result`` leaves out the hypotheses' predictions (the stored
    result keeps them)."""
    mode: Literal["single", "each", "joint"] = (
        "single" if request.record is not None else "joint" if request.joint else "each")
    untimed = [path for path, record in request.items() if record.measured_at is None]
    return DiagnoseResponse(mode=mode, stored=request.store, compact=request.compact,
                            notes=time_notes(untimed, request.store, now),
                            diagnoses=[_public(o, request.compact) for o in outcomes])


def response_json(request: DiagnoseRequest, outcomes: Sequence[DiagnosisOutcome],
                  now: datetime) -> bytes:
    """:func:`response_of` serialised as JSON (pydantic's compiled serialiser)."""
    return response_of(request, outcomes, now).model_dump_json().encode("utf-8")
