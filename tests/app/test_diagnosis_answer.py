"""The answer of ``POST /diagnose`` from one encoding of each result: equal to pydantic's
serialisation of :class:`DiagnoseResponse` (full and compact, stored ids spliced in), and
the rows' documents equal to the result and the records as given, on real diagnoses of the
reference rig (a worn valve, a ratio-only record, readings no hypothesis explains)."""

from __future__ import annotations

import json
import pickle
from datetime import UTC, datetime
from typing import Any

import pytest

from app.schemas.diagnose import DiagnoseRequest, DiagnoseResponse
from app.services.diagnosis import (
    DiagnosisOutcome,
    GroupPlan,
    compute_group,
    outcome_of,
)
from app.services.diagnosis_answer import answer_of, iso_utc
from app.services.diagnosis_form import measurement_record, request_form
from app.services.diagnosis_response import response_json
from app.services.measurements import stored_record
from app.services.rig_cache import ResolvedRig
from sim.rigs import reference_rig, reference_rig_document
from sim.steady import steady_cycle

NOW = datetime(2026, 6, 1, 12, 0, tzinfo=UTC)


@pytest.fixture(scope="module")
def resolved() -> ResolvedRig:
    return ResolvedRig(1, 2, 7, "paper002-reference", reference_rig_document(),
                       reference_rig(), NOW)


def _readings(rig: Any, overrides: dict[str, float]) -> dict[str, Any]:
    cycle = steady_cycle(rig, overrides)
    work, back = cycle.working.values, cycle.return_.values
    return {"pump_pressure": work["P_pump"], "p1": work["P1"], "p2": work["P2"],
            "flow_B": {"value": work["Q_meter_B"], "u": 2.6e-6}, "flow_C": work["Q_meter_C"],
            "speed_work": work["speed"], "speed_return": {"value": back["speed"],
                                                          "bound": 0.004}}


def _requests(rig: Any) -> list[dict[str, Any]]:
    condition = {"oil_temperature": 40.0, "load_force": 2100.0}
    worn = {"rig_id": 1, "condition": condition, "measured_at": "2026-05-01T08:00:00Z",
            **_readings(rig, {"valve.cv": 60e-6})}
    ratio = {"rig_id": 1, "condition": condition,
             "velocity_ratio": steady_cycle(rig).velocity_ratio}
    odd = {"rig_id": 1, "condition": condition, **_readings(rig, {})}
    odd["p1"] = 1.6 * odd["p1"]  # no hypothesis of the library explains this
    return [{"record": worn}, {"record": ratio, "store": False, "compact": True},
            {"records": [odd, worn]}, {"records": [ratio, worn], "joint": True}]


def _outcomes(request: DiagnoseRequest, resolved: ResolvedRig) -> list[DiagnosisOutcome]:
    form = request_form(request)
    groups = [form.records] if form.mode == "joint" else [[r] for r in form.records]
    outcomes = []
    for group in groups:
        times = [r.measured_at or NOW for r in group]
        records = [measurement_record(r, rig_name=resolved.name, measured_at=t)
                   for r, t in zip(group, times, strict=True)]
        plan = GroupPlan([(r.path, r) for r in group], resolved, times, records)
        outcomes.append(outcome_of(plan, compute_group(resolved.rig, records,
                                                       resolved.version)))
    return outcomes


def test_the_answer_is_the_schema_serialisation_and_the_rows_are_what_was_given(
        resolved: ResolvedRig) -> None:
    seen_unexplained = False
    for body in _requests(resolved.rig):
        request = DiagnoseRequest.model_validate(body)
        outcomes = _outcomes(request, resolved)
        seen_unexplained |= any(o.top == "unexplained" for o in outcomes)
        answer = pickle.loads(pickle.dumps(answer_of(request_form(request), outcomes, NOW)))
        reference = json.loads(response_json(request, outcomes, NOW))
        sent = json.loads(answer.body())
        assert sent == reference
        DiagnoseResponse.model_validate(sent)
        if not request.store:
            assert answer.rows == []
            continue
        ids = [(100 + i, [200 + 10 * i + j for j in range(len(o.paths))])
               for i, o in enumerate(outcomes)]
        for outcome, (diagnosis_id, measurement_ids) in zip(outcomes, ids, strict=True):
            outcome.diagnosis_id, outcome.measurement_ids = diagnosis_id, measurement_ids
        assert json.loads(answer.body(ids)) == json.loads(response_json(request, outcomes,
                                                                         NOW))
        items = dict(request.items())
        for outcome, row in zip(outcomes, answer.rows, strict=True):
            assert json.loads(row.result) == outcome.result  # the full result is stored
            assert (row.component, row.probability) == (outcome.component,
                                                          outcome.probability)
            for path, (at, document) in zip(outcome.paths, row.measurements, strict=True):
                assert at == (items[path].measured_at or NOW)
                assert json.loads(document) == stored_record(items[path], at)
            latest = row.measurements[row.latest][0]
            assert latest == max(t for t, _ in row.measurements)
    assert seen_unexplained


def test_the_stored_result_crosses_the_pipe_once() -> None:
    """Full answer and stored row refer to the same encoded result: pickled once."""
    request = DiagnoseRequest.model_validate({"record": {
        "rig_id": 1, "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
        "velocity_ratio": 0.9}})
    rig = reference_rig()
    resolved = ResolvedRig(1, 1, 1, "ref", {}, rig, NOW)
    (outcome,) = _outcomes(request, resolved)
    answer = answer_of(request_form(request), [outcome], NOW)
    (row,) = answer.rows
    assert answer.diagnoses[0][1] is row.result
    assert len(pickle.dumps(answer)) < len(row.result) + len(answer.diagnoses[0][0]) + 2000


def test_times_are_written_as_pydantic_writes_them() -> None:
    assert iso_utc(datetime(2026, 5, 1, 8, 0, tzinfo=UTC)) == "2026-05-01T08:00:00Z"
    stamp = datetime.fromisoformat("2026-05-01T10:00:00.250000+02:00")
    assert iso_utc(stamp) == "2026-05-01T10:00:00.250000+02:00"
