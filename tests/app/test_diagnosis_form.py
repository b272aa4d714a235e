"""The validated form of a ``POST /diagnose`` (what the diagnosis process receives instead
of the body to validate again): the diagnostics record and the stored document it gives are
those of the validated model, for random records, errors included."""

from __future__ import annotations

import pickle
from datetime import UTC, datetime
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.schemas.diagnose import MEASURED_FIELDS, DiagnoseRequest, MeasurementIn
from app.services.diagnosis_form import (
    CONDITION_FIELDS,
    measurement_record,
    record_form,
    request_form,
    stored_document,
)
from app.services.measurements import stored_record, to_record
from sim.errors import InputError, MeasurementError

#: Plausible magnitudes of each field [SI], so that most records are valid ones.
_SCALE = {"pump_pressure": 14e5, "p1": 12e5, "p2": 1.2e5, "flow_B": 4.4e-4, "flow_C": 4e-4,
          "pump_flow": 4.5e-4, "speed_work": 0.18, "speed_return": 0.21, "duration_work": 2.8,
          "duration_return": 2.3, "stroke": 0.5, "velocity_ratio": 0.84,
          "oil_temperature": 40.0, "load_force": 2100.0, "back_pressure": 1e6,
          "pump_speed": 150.0}


@st.composite
def _reading(draw: st.DrawFn, name: str) -> Any:
    value = _SCALE[name] * draw(st.floats(-0.2, 2.0))
    kind = draw(st.sampled_from(["bare", "plain", "u", "bound"]))
    spread = abs(_SCALE[name]) * draw(st.floats(0.0, 0.05))
    return {"bare": value, "plain": {"value": value}, "u": {"value": value, "u": spread},
            "bound": {"value": value, "bound": spread}}[kind]


@st.composite
def _record(draw: st.DrawFn) -> dict[str, Any]:
    condition = {"oil_temperature": draw(_reading("oil_temperature"))}
    for name in CONDITION_FIELDS[1:]:
        if draw(st.booleans()):
            condition[name] = draw(_reading(name))
    record: dict[str, Any] = {"rig_id": draw(st.integers(1, 5)), "condition": condition}
    if draw(st.booleans()):
        record["rig_version"] = draw(st.integers(1, 3))
    if draw(st.booleans()):
        record["measured_at"] = draw(st.sampled_from(
            ["2026-05-01T08:00:00Z", "2026-05-01T10:00:00+02:00", "2026-05-01T08:00:00.25Z"]))
    for name in draw(st.lists(st.sampled_from(list(MEASURED_FIELDS)), unique=True)):
        record[name] = draw(_reading(name))
    if draw(st.booleans()):
        record["calibration_share"] = draw(st.sampled_from([0.0, 0.5, 1]))
    return record


def _outcome(call: Any) -> Any:
    try:
        return call()
    except MeasurementError as exc:
        return ("error", type(exc), exc.message, exc.field)


@settings(max_examples=300, deadline=None)
@given(_record())
def test_the_form_gives_the_models_record_and_stored_document(data: dict[str, Any]) -> None:
    model = MeasurementIn.model_validate(data)
    form = pickle.loads(pickle.dumps(record_form(model, "records[3]")))  # as it crosses
    now = datetime(2026, 6, 1, 12, 0, tzinfo=UTC)
    at = model.measured_at or now
    expected = stored_record(model, at)
    got = stored_document(form, at)
    assert list(got.items()) == list(expected.items())  # same keys in the same order
    built = _outcome(lambda: measurement_record(form, rig_name="rig", measured_at=at))
    reference = _outcome(lambda: to_record(model, path="records[3]", rig_name="rig",
                                           measured_at=at))
    assert built == reference


def test_the_form_keeps_mode_options_and_paths() -> None:
    record = {"rig_id": 1, "condition": {"oil_temperature": 40.0}, "velocity_ratio": 0.84}
    single = request_form(DiagnoseRequest.model_validate({"record": record, "store": False}))
    assert (single.mode, single.store, single.compact) == ("single", False, False)
    assert [r.path for r in single.records] == ["record"]
    joint = request_form(DiagnoseRequest.model_validate(
        {"records": [record, record], "joint": True, "compact": True}))
    assert (joint.mode, joint.store, joint.compact) == ("joint", True, True)
    assert [r.path for r in joint.records] == ["records[0]", "records[1]"]
    assert joint.records[1].readings == {"velocity_ratio": (0.84, None, None)}
    with pytest.raises(InputError) as both:
        request_form(DiagnoseRequest.model_validate({"record": record, "records": [record]}))
    assert both.value.field == "records"
