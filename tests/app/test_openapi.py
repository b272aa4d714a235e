"""The OpenAPI document: every field documented with its unit and an example."""

from __future__ import annotations

import re
from typing import Any

import pytest

from tests.app.live import LiveServer

UNIT = re.compile(r"\[[^\]]+\]")


@pytest.fixture(scope="module")
def spec(server: LiveServer) -> dict[str, Any]:
    response = server.client.get("/openapi.json")
    assert response.status_code == 200
    return dict(response.json())


def _own_schemas(spec: dict[str, Any]) -> dict[str, Any]:
    # FastAPI's generic validation-error schemas are not hydrodiag's; they never appear in
    # answers because app.errors replaces that body.
    return {name: schema for name, schema in spec["components"]["schemas"].items()
            if name not in {"HTTPValidationError", "ValidationError"}}


def test_every_field_has_a_unit_and_an_example(spec: dict[str, Any]) -> None:
    problems = []
    for name, schema in _own_schemas(spec).items():
        for field, prop in schema.get("properties", {}).items():
            description = prop.get("description", "")
            if not UNIT.search(description):
                problems.append(f"{name}.{field}: no [unit] in {description!r}")
            if not prop.get("examples"):
                problems.append(f"{name}.{field}: no examples")
    assert problems == []


def test_every_parameter_has_a_unit_and_an_example(spec: dict[str, Any]) -> None:
    problems = []
    for path, operations in spec["paths"].items():
        for method, operation in operations.items():
            if not operation.get("summary"):
                problems.append(f"{method} {path}: no summary")
            for parameter in operation.get("parameters", []):
                label = f"{method} {path} {parameter['name']}"
                if not UNIT.search(parameter.get("description", "")):
                    problems.append(f"{label}: no [unit]")
                if not (parameter.get("examples") or parameter.get("schema", {}).get("examples")):
                    problems.append(f"{label}: no examples")
    assert problems == []


def test_writes_declare_the_api_key_and_errors_use_the_common_body(spec: dict[str, Any]) -> None:
    assert spec["components"]["securitySchemes"]["APIKeyHeader"]["name"] == "X-API-Key"
    for path, operations in spec["paths"].items():
        for method, operation in operations.items():
            if method in {"post", "put", "patch", "delete"}:
                assert {"APIKeyHeader": []} in operation.get("security", []), (method, path)
                # the header that makes a retry safe, where a generated client offers it
                # (only in the introduction before: an API client's pass)
                assert "Idempotency-Key" in [p["name"] for p in operation["parameters"]], \
                    (method, path)
            if operation.get("x-hydrodiag-access") != "open":
                # a store that does not answer is a 503 on any keyed operation (only two
                # listed it: an API client's pass)
                assert "503" in operation["responses"], (method, path)
            for status in ("401", "404", "409", "422", "503"):
                if status in operation.get("responses", {}):
                    content = operation["responses"][status]["content"]["application/json"]
                    assert content["schema"]["$ref"].endswith("/ErrorBody"), (method, path)


def test_the_routes_of_the_service_are_there(spec: dict[str, Any]) -> None:
    assert set(spec["paths"]) == {
        "/health", "/ready", "/metrics", "/rigs", "/rigs/{rig_id}", "/rigs/{rig_id}/versions",
        "/rigs/{rig_id}/versions/{version}", "/rigs/{rig_id}/calibrations",
        "/rigs/{rig_id}/calibrations/{calibration_id}",
        "/rigs/{rig_id}/calibrations/{calibration_id}/clearance", "/pump-sets",
        "/pump-sets/{pump_set_id}", "/jobs", "/jobs/{job_id}", "/jobs/{job_id}/cancel",
        "/rigs/{rig_id}/trends",
        "/pump-sets/bench", "/diagnose", "/simulate", "/scenarios", "/rigs/{rig_id}/commission",
        "/rigs/{rig_id}/rediagnose",
        "/rigs/{rig_id}/series", "/series/{series_id}", "/series/{series_id}/record",
        "/measurements",
        "/measurements/{measurement_id}", "/diagnoses", "/diagnoses/{diagnosis_id}",
        "/discrepancy", "/rigs/{rig_id}/pump-leak",
    }


@pytest.mark.parametrize("page", ["/docs", "/redoc"])
def test_the_documentation_pages_need_no_internet(server: LiveServer, page: str) -> None:
    """Swagger UI and ReDoc came from cdn.jsdelivr.net: blank pages on a plant network
    without the internet (a first-day user pass); now every file is the service's own."""
    html = server.anon.get(page)
    assert html.status_code == 200
    links = re.findall(r'(?:src|href)="([^"]+)"', html.text)
    assert links and not [u for u in links if "://" in u or u.startswith("//")], links
    for url in links:  # served without a key, each a real file
        got = server.anon.get(url)
        assert got.status_code == 200 and len(got.content) > 1000, url
