"""Bounded input: integers past the store's range, unknown fields, oversized bodies.

Issue 16 item 2 (integers past 64 bits gave SQLite's OverflowError, a 500) and issue 14
(unknown fields silently ignored; no body size limit; ``/health`` queued behind work).
"""

from __future__ import annotations

import inspect
from collections.abc import Iterator
from typing import Any

import pytest

from app.api.routes.ops import health
from app.schemas.common import MAX_ID
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer, live_server, store_settings

HUGE = 9223372036854775808  # 2**63: past SQLite's INTEGER
JUST_PAST = MAX_ID + 1


@pytest.mark.parametrize(("method", "path", "field"), [
    ("GET", f"/pump-sets/{HUGE}", "pump_set_id"),
    ("PATCH", f"/pump-sets/{HUGE}", "pump_set_id"),
    ("DELETE", f"/pump-sets/{JUST_PAST}", "pump_set_id"),
    ("GET", f"/rigs/{HUGE}", "rig_id"),
    ("DELETE", f"/rigs/{HUGE}", "rig_id"),
    ("GET", f"/rigs/{JUST_PAST}/versions", "rig_id"),
    ("GET", f"/rigs/1/versions/{HUGE}", "version"),
    ("GET", f"/rigs/1/calibrations/{HUGE}", "calibration_id"),
    ("GET", f"/rigs/{HUGE}/calibrations/1/clearance?opening_turns=0.2", "rig_id"),
    ("GET", f"/rigs/{HUGE}/trends", "rig_id"),
    ("GET", f"/rigs?offset={HUGE}", "offset"),
    ("GET", f"/pump-sets?rig_id={HUGE}", "rig_id"),
    ("GET", f"/jobs?offset={JUST_PAST}", "offset"),
])
def test_integers_past_the_store_are_422_naming_them(server: LiveServer, method: str,
                                                     path: str, field: str) -> None:
    body = {"name": "x"} if method == "PATCH" else None
    response = server.client.request(method, path, json=body)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == field


def test_the_largest_id_is_a_plain_404(server: LiveServer) -> None:
    response = server.client.get(f"/rigs/{MAX_ID}")
    assert response.status_code == 404
    assert server.client.get(f"/rigs?offset={MAX_ID}").json()["items"] == []


@pytest.mark.parametrize(("path", "body", "field"), [
    ("/pump-sets", {"name": "big", "kind": "parameters", "pump": "gear", "rig_id": HUGE,
                    "quantities": {"Cs": {"value": 1.0, "unit": "1"}}}, "rig_id"),
    ("/diagnose", {"record": {"rig_id": HUGE, "condition": {"oil_temperature": 40.0},
                              "p1": 1e6}}, "record.rig_id"),
    ("/diagnose", {"record": {"rig_id": 1, "rig_version": HUGE,
                              "condition": {"oil_temperature": 40.0}, "p1": 1e6}},
     "record.rig_version"),
    ("/scenarios", {"rig_id": HUGE}, "rig_id"),
])
def test_body_integers_past_the_store_are_422(server: LiveServer, path: str,
                                              body: dict[str, Any], field: str) -> None:
    before = server.row_counts()
    response = server.client.post(path, json=body)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == field
    assert server.row_counts() == before


def test_an_integer_no_schema_bounds_is_still_a_422(server: LiveServer) -> None:
    # /simulate's fields belong to the solver's schema; the store's refusal is mapped too
    response = server.client.post("/simulate", json={"rig_id": HUGE, "method": "steady"})
    assert response.status_code == 422, response.text


def test_misspelt_fields_are_refused_with_the_close_name(server: LiveServer) -> None:
    record = simulated_record(server)
    record["flow_b"] = record.pop("flow_B")
    record["flowC"] = record.pop("flow_C")
    before = server.row_counts()
    response = server.client.post("/diagnose", json={"record": record})
    assert response.status_code == 422, response.text
    error = response.json()["error"]
    assert error["field"] == "record.flow_b"
    assert "'flow_b' (did you mean 'flow_B'?)" in error["message"]
    assert "'flowC' (did you mean 'flow_C'?)" in error["message"]
    assert server.row_counts() == before


def test_a_validators_sentence_reads_as_written(server: LiveServer) -> None:
    # an operator pass: a refused fault name read "Value error, unknown fault ..."
    response = server.client.post("/scenarios", json={"rig_id": 1,
                                                      "faults": ["worn_piston_seal"]},
                                  headers=server.auth)
    assert response.status_code == 422, response.text
    message = response.json()["error"]["message"]
    assert message.startswith("unknown fault 'worn_piston_seal'"), message


@pytest.mark.parametrize(("path", "body", "field", "hint"), [
    ("/scenarios", {"rig_id": 1, "parameter": [{"name": "valve.cv", "low": 3e-5,
                                                  "high": 8e-5}]}, "parameter", "parameters"),
    ("/scenarios", {"rig_id": 1, "parameters": [{"name": "valve.cv", "low": 3e-5,
                                                   "high": 8e-5, "level": 5}]},
     "parameters[0].level", "levels"),
    ("/simulate", {"rig_id": 1, "conditon": {"load": 2100.0}}, "conditon", "condition"),
    ("/rigs/1/calibrations", {"throttle": "I", "component": "valve", "back_pressure_pa": 1e6,
                              "temperature_c": 40.0, "points": [], "sorce": "x"},
     "sorce", "source"),
    ("/pump-sets", {"name": "n", "kind": "parameters", "pump": "p", "quantities": {
        "Cs": {"value": 1.0, "units": "1"}}}, "quantities.Cs.units", "unit"),
    ("/rigs", {"document": {}, "coment": "x"}, "coment", "comment"),
])
def test_unknown_fields_are_422_in_every_request_model(server: LiveServer, path: str,
                                                       body: dict[str, Any], field: str,
                                                       hint: str) -> None:
    before = server.row_counts()
    response = server.client.post(path, json=body)
    assert response.status_code == 422, response.text
    error = response.json()["error"]
    assert error["field"] == field, error
    assert f"did you mean {hint!r}" in error["message"]
    assert server.row_counts() == before


@pytest.mark.parametrize(("path", "body", "field", "name"), [
    ("/simulate", {"rig_id": 1, "condition": {"load_force": 2100.0}}, "condition.load_force",
     "load"),
    ("/diagnose", {"record": {"rig_id": 1, "condition": {"oil_temperature": 40.0,
                                                         "load": 2100.0}, "p1": 1.2e6}},
     "record.condition.load", "load_force"),
])
def test_the_loads_other_name_is_pointed_to(server: LiveServer, path: str,
                                            body: dict[str, Any], field: str,
                                            name: str) -> None:
    """A simulation's condition names the load ``load``, a diagnosis record's ``load_force``
    (a reading with its uncertainty): the other operation's name gets a 422 naming this one."""
    before = server.row_counts()
    response = server.client.post(path, json=body)
    assert response.status_code == 422, response.text
    error = response.json()["error"]
    assert error["field"] == field, error
    assert f"(here it is {name!r})" in error["message"]
    assert server.row_counts() == before


def test_every_request_model_forbids_unknown_fields(server: LiveServer) -> None:
    spec = server.client.get("/openapi.json").json()
    schemas = spec["components"]["schemas"]
    inputs = [name for name in schemas
              if name.endswith(("Create", "Update", "Request", "In", "Spec", "Form"))
              or name in {"Quantity"}]
    assert len(inputs) >= 12
    open_ = [n for n in inputs if schemas[n].get("additionalProperties") is not False]
    # the form models are combined with the file part in the operation's body schema
    assert sorted(open_) == ["DiscrepancyForm", "PumpBenchForm", "SeriesImportForm"]


def test_an_unknown_form_field_is_refused(server: LiveServer) -> None:
    response = server.client.post("/pump-sets/bench", data={
        "name": "n", "pump": "p", "sourse": "x"}, files={"file": ("b.csv", b"x", "text/csv")})
    assert response.status_code == 422
    assert response.json()["error"]["field"] == "sourse"
    assert "did you mean 'source'" in response.json()["error"]["message"]


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    settings = store_settings(tmp_path_factory.mktemp("small"), max_body_bytes=4096,
                               max_upload_bytes=64 * 1024)
    with live_server(settings) as live:
        yield live


def test_a_body_over_the_limit_is_413_naming_it(small: LiveServer) -> None:
    before = small.row_counts()
    big = {"document": {"name": "x" * 10_000}}
    response = small.client.post("/rigs", json=big)
    assert response.status_code == 413
    error = response.json()["error"]
    assert error["type"] == "PayloadTooLargeError" and error["field"] == "body"
    assert "4096 bytes" in error["message"] and "HYDRODIAG_MAX_BODY_BYTES" in error["message"]

    def chunks() -> Iterator[bytes]:  # no Content-Length: counted as it arrives
        yield b'{"document": {"name": "'
        for _ in range(100):
            yield b"y" * 1000
        yield b'"}}'

    streamed = small.client.post("/rigs", content=chunks(),
                                 headers={"Content-Type": "application/json"})
    assert streamed.status_code == 413
    assert small.row_counts() == before
    assert small.client.get("/health").status_code == 200
    small_body = small.client.post("/rigs", json={"document": {}})
    assert small_body.status_code == 422  # under the limit: read and validated as usual


def _series_csv(rows: int) -> bytes:
    """A measured pump-pressure trace of ``rows`` samples at 1 kHz (~22 bytes a row)."""
    lines = ["t [s],p_pump [bar]"] + [f"{i / 1000:.3f},{80 + (i % 50) / 10:.6f}"
                                      for i in range(rows)]
    return ("\n".join(lines) + "\n").encode()


def test_a_file_upload_has_its_own_larger_limit(small: LiveServer) -> None:
    # a series file larger than the JSON body limit is read (multipart has its own limit)
    content = _series_csv(1000)
    assert 4096 < len(content) < 64 * 1024
    response = small.client.post("/rigs/1/series", data={"name": "over-json-limit"},
                                 files={"file": ("cycle.csv", content, "text/csv")},
                                 headers=small.auth)
    assert response.status_code == 201, response.text
    assert response.json()["items"][0]["n_samples"] == 1000
    before = small.row_counts()
    too_big = _series_csv(5000)
    assert len(too_big) > 64 * 1024
    refused = small.client.post("/rigs/1/series", data={"name": "over-upload-limit"},
                                files={"file": ("cycle.csv", too_big, "text/csv")},
                                headers=small.auth)
    assert refused.status_code == 413
    message = refused.json()["error"]["message"]
    assert "65536 bytes" in message and "HYDRODIAG_MAX_UPLOAD_BYTES" in message
    assert small.row_counts() == before
    # a JSON body cannot pass as an upload: its own content type decides its limit
    big = small.client.post("/rigs", content=b'{"document": {"name": "' + b"x" * 10_000 + b'"}}',
                            headers={**small.auth, "Content-Type": "application/json"})
    assert big.status_code == 413 and "HYDRODIAG_MAX_BODY_BYTES" in big.json()["error"]["message"]


def test_413_is_documented_and_the_default_limit_is_a_setting(server: LiveServer) -> None:
    assert server.settings.max_body_bytes == 8 * 1024 * 1024
    assert server.settings.max_upload_bytes == 64 * 1024 * 1024
    spec = server.client.get("/openapi.json").json()
    assert "413" in spec["paths"]["/diagnose"]["post"]["responses"]


def test_health_runs_on_the_event_loop_and_touches_nothing(server: LiveServer) -> None:
    # an async route is not sent to the worker threads that diagnoses occupy
    assert inspect.iscoroutinefunction(health)
    assert list(inspect.signature(health).parameters) == []
    assert server.anon.get("/health").json()["status"] == "ok"


@pytest.mark.parametrize(("path", "body", "field"), [
    ("/scenarios", {"rig_id": 1, "seed": False}, "seed"),
    ("/scenarios", {"rig_id": True}, "rig_id"),
    ("/simulate", {"rig_id": 1, "condition": {"oil_temperature": False}},
     "condition.oil_temperature"),
    ("/simulate", {"rig_id": 1, "overrides": {"valve.cv": "6e-5"}}, "overrides"),
    ("/pump-sets", {"name": "kinds", "kind": "parameters", "pump": "p", "quantities": {
        "A": {"value": [[False]], "unit": "1"}}}, "quantities.A.value"),
    ("/pump-sets", {"name": "kinds", "kind": "parameters", "pump": "p", "quantities": {
        "A": {"value": [False], "unit": "1"}}}, "quantities.A.value"),
    ("/diagnose", {"record": {"rig_id": 1, "measured_at": 0.5,
                              "condition": {"oil_temperature": 40.0}}}, "record.measured_at"),
])
def test_json_kinds_are_not_coerced(server: LiveServer, path: str, body: dict[str, Any],
                                    field: str) -> None:
    """Found by Schemathesis: ``false`` read as 0, ``"6e-5"`` as a number, ``0.5`` as a
    date were accepted although the document says number or date-time."""
    before = server.row_counts()
    response = server.client.post(path, json=body)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == field
    assert server.row_counts() == before


@pytest.mark.parametrize("path", ["/diagnoses", "/measurements", "/rigs/1/trends"])
def test_times_in_queries_are_iso_8601_only(server: LiveServer, path: str) -> None:
    response = server.client.get(path, params={"until": "0.5"})
    assert response.status_code == 422
    assert response.json()["error"]["field"] == "until"
    assert server.client.get(path, params={"until": "2026-01-01T00:00:00Z"}).status_code == 200


def test_malformed_json_names_the_body_and_the_position(server: LiveServer) -> None:
    response = server.client.post("/pump-sets", content=b'{"name": ',
                                  headers={"Content-Type": "application/json"})
    assert response.status_code == 422
    error = response.json()["error"]
    assert error["field"] == "body" and "at character 9" in error["message"]


@pytest.mark.parametrize(("path", "params", "field", "hint"), [
    ("/diagnoses", {"rigid": "1"}, "rigid", "rig_id"),  # answered the unfiltered list
    ("/rigs/1/trends", {"componnet": "valve"}, "componnet", "component"),
    ("/series/1/record", {"oil_temprature": "40"}, "oil_temprature", "oil_temperature"),
    ("/rigs", {"limit": "5", "ofset": "1"}, "ofset", "offset"),
])
def test_an_unknown_query_parameter_is_refused_naming_the_close_one(
        server: LiveServer, path: str, params: dict[str, str], field: str, hint: str) -> None:
    response = server.client.get(path, params=params)
    assert response.status_code == 422, response.text
    error = response.json()["error"]
    assert error["field"] == field and f"did you mean {hint!r}" in error["message"]


def test_known_query_parameters_and_health_pass(server: LiveServer) -> None:
    assert server.client.get("/rigs", params={"limit": 5, "offset": 0}).status_code == 200
    assert server.client.get("/diagnoses", params={"rig_id": 1}).status_code == 200
    assert server.anon.get("/health", params={"probe": "1"}).status_code == 200


@pytest.mark.parametrize("path", ["/series/99999999999999999999", "/rigs/99999999999999999999/series",
                                  "/series/2147483648/record"])
def test_every_id_in_a_path_is_bounded(server: LiveServer, path: str) -> None:
    """As every other route: a 422 naming the id, not the SQLite driver's "Python int too
    large to convert" with no field."""
    response = server.client.get(path)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] in ("series_id", "rig_id")


def test_a_body_of_another_type_is_told_to_be_json(server: LiveServer) -> None:
    """Sent as text/plain (curl -d without a header), a JSON route's body was refused as
    "Input should be a valid dictionary"; the message now says what to send."""
    before = server.row_counts()
    response = server.client.post("/diagnose", content=b'{"record": {}}', headers={
        **server.auth, "Content-Type": "text/plain"})
    assert response.status_code == 422
    error = response.json()["error"]
    assert error["field"] == "body" and "Content-Type: application/json" in error["message"]
    # curl -d's own default, a form: told the same, with the curl fix (was "Input should
    # be a valid dictionary or object to extract fields from"; an operator pass)
    form = server.client.post("/diagnose", content=b'{"record": {}}', headers={
        **server.auth, "Content-Type": "application/x-www-form-urlencoded"})
    assert form.status_code == 422 and "curl -d sends a form" in form.json()["error"]["message"]
    assert server.row_counts() == before


@pytest.mark.parametrize(("method", "path", "kwargs", "field", "words"), [
    ("get", "/rigs/1/calibrations/1/clearance", {"params": {"opening_turns": "nan"}},
     "opening_turns[0]", "finite"),  # was "opening nan turn is outside the calibrated range"
    ("post", "/discrepancy", {"data": {"rig_id": "1", "series_ids": "1", "relaxation": "nan"}},
     "relaxation", "finite"),  # was "should be less than or equal to 60"
    ("get", "/rigs/1/trends", {"params": {"since": "2026-05-01T00:00:00Z",
                                          "until": "2026-04-01T00:00:00Z"}},
     "until", "before"),  # answered 200 with empty trends; /diagnoses answered 422
])
def test_nan_and_reversed_windows_are_named_as_such(server: LiveServer, method: str, path: str,
                                                    kwargs: dict[str, Any], field: str,
                                                    words: str) -> None:
    response = getattr(server.client, method)(path, headers=server.auth, **kwargs)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == field
    assert words in response.json()["error"]["message"]
