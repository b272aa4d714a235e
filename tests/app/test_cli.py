"""The command line: `serve` end to end in a subprocess, `keys` and `db` in process."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest
from typer.testing import CliRunner

from app.cli import cli

STARTUP_TIMEOUT_S = 60.0


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@contextmanager
def _serve(data_dir: Path) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    port = _free_port()
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(data_dir)}
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )
    base_url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while True:
            if process.poll() is not None:
                raise AssertionError(f"serve exited with {process.returncode}")
            try:
                if httpx.get(f"{base_url}/health", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline:
                raise AssertionError("serve did not answer /health in time")
            time.sleep(0.1)
        yield base_url, process
    finally:
        process.terminate()
        process.wait(timeout=30)


def _keys_printed(process: subprocess.Popen[str]) -> list[str]:
    assert process.stdout is not None
    return [line.split(": ", 1)[1].strip() for line in process.stdout.read().splitlines()
            if line.startswith("API key: ")]


def test_serve_migrates_preloads_and_prints_the_first_key_once(tmp_path: Path) -> None:
    with _serve(tmp_path) as (base_url, process):
        rigs = httpx.get(f"{base_url}/rigs").json()
        assert [r["name"] for r in rigs["items"]] == ["paper002-reference"]
        assert httpx.get(f"{base_url}/ready").status_code == 200
    keys = _keys_printed(process)
    assert len(keys) == 1
    document = rigs["items"][0]["document"] | {"name": "cli-rig"}
    with _serve(tmp_path) as (base_url, process):
        created = httpx.post(f"{base_url}/rigs", json={"document": document},
                             headers={"X-API-Key": keys[0]})
        assert created.status_code == 201, created.text
        assert httpx.get(f"{base_url}/rigs").json()["total"] == 2
    assert _keys_printed(process) == []
    assert (tmp_path / "hydrodiag.db").exists()


@pytest.fixture
def runner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> CliRunner:
    monkeypatch.setenv("HYDRODIAG_DATA_DIR", str(tmp_path))
    monkeypatch.delenv("HYDRODIAG_DATABASE_URL", raising=False)
    return CliRunner()


def test_db_upgrade_and_current(runner: CliRunner) -> None:
    assert runner.invoke(cli, ["db", "current"]).output.strip() == ""
    result = runner.invoke(cli, ["db", "upgrade"])
    assert result.exit_code == 0, result.output
    from app.db.migrate import head_revision

    assert runner.invoke(cli, ["db", "current"]).output.strip() == head_revision() != ""


def test_keys_create_list_revoke(runner: CliRunner) -> None:
    created = runner.invoke(cli, ["keys", "create", "--name", "lab-pc"])
    assert created.exit_code == 0, created.output
    key = created.output.strip()
    assert key.startswith("hd_")
    listed = runner.invoke(cli, ["keys", "list"]).output
    assert "lab-pc" in listed and key not in listed and key.split("_")[1] in listed
    duplicate = runner.invoke(cli, ["keys", "create", "--name", "lab-pc"])
    assert duplicate.exit_code != 0
    revoked = runner.invoke(cli, ["keys", "revoke", "1"])
    assert revoked.exit_code == 0, revoked.output
    assert "revoked" in revoked.output


def test_bad_configuration_exits_with_a_message(runner: CliRunner,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HYDRODIAG_DATABASE_URL", "postgresql://u:password@db/x")
    result = runner.invoke(cli, ["db", "current"])
    assert result.exit_code == 2
    assert "well-known default" in result.output


def test_main_reports_hydrodiag_errors_without_a_traceback(tmp_path: Path) -> None:
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(tmp_path)}
    result = subprocess.run([sys.executable, "-m", "app.cli", "keys", "revoke", "7"],
                            env=env, capture_output=True, text=True, check=False)
    assert result.returncode == 1
    assert "NotFoundError" in result.stderr and "Traceback" not in result.stderr
