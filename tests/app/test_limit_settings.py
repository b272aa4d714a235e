"""Limits as settings (issue 14): batch length and sweep size, each answered with a 422
that names the limit and its setting, nothing stored; the settings' own bounds."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from pydantic import ValidationError

from app.limits import BATCH_RECORDS_CEILING
from app.settings import Settings
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer, live_server, store_settings
from tests.app.test_scenarios import SWEEP


@pytest.fixture(scope="module")
def tight(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    """A server with small limits: 3 records, 11 steady and 2 transient sweep points."""
    settings = store_settings(tmp_path_factory.mktemp("tight"), max_batch_records=3,
                               max_sweep_points_steady=11, max_sweep_points_transient=2)
    with live_server(settings) as live:
        yield live


def _refused(response: Any, field: str, setting: str, limit: int) -> None:
    assert response.status_code == 422, response.text
    error = response.json()["error"]
    assert error["field"] == field
    assert setting in error["message"] and f"at most {limit}" in error["message"]


def test_a_batch_over_the_setting_is_refused_and_one_at_it_answered(tight: LiveServer) -> None:
    record = simulated_record(tight)
    before = tight.row_counts()
    _refused(tight.client.post("/diagnose", json={"records": [record] * 4}), "records",
             "HYDRODIAG_MAX_BATCH_RECORDS", 3)
    assert tight.row_counts() == before
    answered = tight.client.post("/diagnose", json={"records": [record] * 3, "store": False})
    assert answered.status_code == 200, answered.text
    assert len(answered.json()["diagnoses"]) == 3
    assert tight.row_counts() == before


def test_the_default_batch_limit_is_100(server: LiveServer) -> None:
    record = simulated_record(server)
    before = server.row_counts()
    _refused(server.client.post("/diagnose", json={"records": [record] * 101}), "records",
             "HYDRODIAG_MAX_BATCH_RECORDS", 100)
    past_ceiling = server.client.post(
        "/diagnose", json={"records": [record] * (BATCH_RECORDS_CEILING + 1)})
    assert past_ceiling.status_code == 422
    assert past_ceiling.json()["error"]["field"] == "records"
    assert server.row_counts() == before


@pytest.mark.parametrize(("method", "setting", "limit"), [
    ("steady", "HYDRODIAG_MAX_SWEEP_POINTS_STEADY", 11),
    ("transient", "HYDRODIAG_MAX_SWEEP_POINTS_TRANSIENT", 2),
])
def test_a_sweep_over_the_setting_is_refused(tight: LiveServer, method: str, setting: str,
                                             limit: int) -> None:
    before = tight.row_counts()
    _refused(tight.client.post("/scenarios", json=SWEEP | {"method": method}), "design",
             setting, limit)
    assert tight.row_counts() == before


@pytest.mark.parametrize(("variable", "value"), [
    ("HYDRODIAG_MAX_BATCH_RECORDS", "0"),
    ("HYDRODIAG_MAX_BATCH_RECORDS", str(BATCH_RECORDS_CEILING + 1)),
    ("HYDRODIAG_MAX_SWEEP_POINTS_STEADY", "-1"),
    ("HYDRODIAG_MAX_SWEEP_POINTS_TRANSIENT", "1e9"),
])
def test_limit_settings_are_bounded(monkeypatch: pytest.MonkeyPatch, variable: str,
                                    value: str) -> None:
    monkeypatch.setenv(variable, value)
    with pytest.raises(ValidationError, match=variable.removeprefix("HYDRODIAG_").lower()):
        Settings()


def test_limit_settings_are_read_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HYDRODIAG_MAX_BATCH_RECORDS", "250")
    monkeypatch.setenv("HYDRODIAG_MAX_SWEEP_POINTS_TRANSIENT", "40")
    settings = Settings()
    assert settings.max_batch_records == 250
    assert settings.sweep_points == {"steady": 5000, "transient": 40}
