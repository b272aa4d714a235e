"""The service under study for ``make chaos``: ``hydrodiag serve`` in a subprocess on a free
loopback port, started, stopped and waited on (:mod:`benchmarks.chaos`)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import httpx

from app.cli import first_key_shown

__all__ = ["STARTUP_TIMEOUT_S", "Server", "running", "start", "stop", "wait_ready"]

STARTUP_TIMEOUT_S = 300.0  # generous: restarts share 2 cores with other work


@dataclass
class Server:
    """A running ``hydrodiag serve`` on ``data_dir``."""

    base_url: str
    data_dir: Path
    process: subprocess.Popen[str]
    key: str = ""

    @property
    def auth(self) -> dict[str, str]:
        return {"X-API-Key": self.key}

    def rss_mb(self) -> float:
        """Resident memory of the server process [MiB]."""
        for line in Path(f"/proc/{self.process.pid}/status").read_text(encoding="utf-8").splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
        return float("nan")


def _free_port() -> int:
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _start_once(data_dir: Path, key: str, database_url: str | None,
                found: list[str]) -> Server:
    port = _free_port()
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(data_dir), "HYDRODIAG_ACCESS_LOG": "false",
                        "HYDRODIAG_LOG_LEVEL": "warning"}
    if database_url is not None:
        env["HYDRODIAG_DATABASE_URL"] = database_url
    log = (data_dir / "service.log").open("a")
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
        env=env, stdout=subprocess.PIPE, stderr=log, text=True)
    server = Server(f"http://127.0.0.1:{port}", data_dir, process, key)
    assert process.stdout is not None
    if not key:
        for line in process.stdout:
            if (shown := first_key_shown(line)) is not None:
                server.key = shown
                found.append(server.key)
                break
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while True:
        try:
            if httpx.get(f"{server.base_url}/health", timeout=5).status_code == 200:
                return server
        except httpx.TransportError:
            pass
        if process.poll() is not None or time.monotonic() > deadline:
            if process.poll() is None:
                process.kill()
                process.wait(timeout=30)
            tail = (data_dir / "service.log").read_text(errors="replace")[-2000:]
            raise RuntimeError(f"the service did not start (exit {process.returncode}); "
                               f"end of {data_dir}/service.log:\n{tail}")
        time.sleep(0.1)


def start(data_dir: Path, key: str = "", database_url: str | None = None) -> Server:
    """Start the service on ``data_dir`` (its store there, or at ``database_url``); read
    the first-start key when there is one.

    A start that fails (no ``/health`` within :data:`STARTUP_TIMEOUT_S`, or the process
    exits) is tried once more on another port, after printing why; a second failure raises
    with the end of the service's log.
    """
    found: list[str] = []  # the first-start key, printed once even if that start fails
    try:
        return _start_once(data_dir, key, database_url, found)
    except RuntimeError as exc:
        print(f"retrying a failed start: {exc}", file=sys.stderr)
        return _start_once(data_dir, key or (found[0] if found else ""), database_url, found)


def stop(server: Server) -> None:
    """Stop the server gracefully (SIGTERM), or kill it if it does not go."""
    server.process.terminate()
    try:
        server.process.wait(timeout=30)
    except subprocess.TimeoutExpired:
        server.process.kill()
        server.process.wait(timeout=30)


def wait_ready(server: Server) -> None:
    """Wait until ``/ready`` answers 200 (store migrated, rigs loaded)."""
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while httpx.get(f"{server.base_url}/ready", timeout=10).status_code != 200:
        if time.monotonic() > deadline:
            raise RuntimeError("the service did not become ready")
        time.sleep(0.2)


@contextmanager
def running(data_dir: Path) -> Iterator[Server]:
    """A ready server on ``data_dir`` for the block, stopped after it."""
    server = start(data_dir)
    try:
        wait_ready(server)
        yield server
    finally:
        stop(server)
