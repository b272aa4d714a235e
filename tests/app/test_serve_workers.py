"""``hydrodiag serve`` with several workers: a ``kill -9`` of the supervisor leaves no orphan
behind (server workers and their diagnosis workers end themselves)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

STARTUP_TIMEOUT_S = 240.0


def _children(pid: int) -> set[int]:
    """Every live descendant of ``pid`` (from /proc)."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[0] != "Z":
            parents[int(entry.name)] = int(fields[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier}
        found |= frontier
    return found


def _alive(pid: int) -> bool:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return False
    return fields[0] != "Z"


def test_a_killed_supervisor_takes_its_workers_with_it(tmp_path: Path) -> None:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(tmp_path), "HYDRODIAG_WORKERS": "2",
                        "HYDRODIAG_ACCESS_LOG": "false", "HYDRODIAG_LOG_LEVEL": "warning"}
    log = (tmp_path / "service.log").open("w")
    supervisor = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
        env=env, stdout=log, stderr=log)
    descendants: set[int] = set()
    try:
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while True:
            try:
                if httpx.get(f"http://127.0.0.1:{port}/ready", timeout=5).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            assert supervisor.poll() is None, (tmp_path / "service.log").read_text()
            assert time.monotonic() < deadline, "the service did not become ready"
            time.sleep(0.2)
        # 2 server workers, each with its diagnosis worker (and spawn's resource trackers)
        while len(descendants) < 4 and time.monotonic() < deadline:
            descendants = _children(supervisor.pid)
            time.sleep(0.2)
        assert len(descendants) >= 4
        supervisor.send_signal(signal.SIGKILL)
        supervisor.wait(timeout=30)
        deadline = time.monotonic() + 30
        while any(_alive(p) for p in descendants) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not [p for p in descendants if _alive(p)]
    finally:
        if supervisor.poll() is None:
            supervisor.kill()
        for pid in descendants:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
        log.close()
