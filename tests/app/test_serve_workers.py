"""``hydrodiag serve`` with several workers: a ``kill -9`` of the supervisor leaves no orphan
behind (server workers and their diagnosis workers end themselves); ``/metrics`` counts the
requests of every worker, whichever answers the scrape."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from tests.app.conftest import first_api_key
from tests.app.live import store_database_url

STARTUP_TIMEOUT_S = 240.0
#: HYDRODIAG_KEEP_ALIVE_S of the served service [s]
KEEP_ALIVE_S = 2


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


def _serve(tmp_path: Path, cwd: Path | None = None, **settings: str
           ) -> tuple[subprocess.Popen[bytes], int]:
    """``hydrodiag serve`` with 2 workers on a free port, once it is ready (``settings``:
    more variables); ``cwd``: started there by its console script, as a user types it."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(tmp_path), "HYDRODIAG_WORKERS": "2",
                        "HYDRODIAG_ACCESS_LOG": "false", "HYDRODIAG_LOG_LEVEL": "warning",
                        "HYDRODIAG_KEEP_ALIVE_S": str(KEEP_ALIVE_S)} | settings
    # the store: the folder's SQLite file, or a database of its own under make test-postgres
    # (the workers' connections to one PostgreSQL store)
    url = store_database_url()
    env.pop("HYDRODIAG_DATABASE_URL", None)
    if url is not None:
        env["HYDRODIAG_DATABASE_URL"] = url
    env.pop("PROMETHEUS_MULTIPROC_DIR", None)
    env.pop("MALLOC_ARENA_MAX", None)  # serve sets it
    (tmp_path / "tmp").mkdir()
    env["TMPDIR"] = str(tmp_path / "tmp")  # where the metrics folder goes
    with (tmp_path / "service.log").open("w") as log:
        command = ([sys.executable, "-m", "app.cli"] if cwd is None
                   else [str(Path(sys.executable).with_name("hydrodiag"))])
        supervisor = subprocess.Popen(
            [*command, "serve", "--host", "127.0.0.1", "--port", str(port)], env=env,
            stdout=log, stderr=log, cwd=cwd)
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while True:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/ready", timeout=5).status_code == 200:
                return supervisor, port
        except httpx.TransportError:
            pass
        if supervisor.poll() is not None or time.monotonic() > deadline:
            supervisor.kill()
            pytest.fail("the service did not become ready:\n"
                        + (tmp_path / "service.log").read_text())
        time.sleep(0.2)


def _parent(pid: int) -> int:
    """The parent process id of ``pid``."""
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])


def _login_cookie(tmp_path: Path, port: int, *, behind_tls: bool) -> str:
    """The console's login cookie for ``serve``'s first key, as ``Set-Cookie`` says it, the
    request sent as a TLS-terminating proxy forwards it (``X-Forwarded-Proto: https``) or
    directly."""
    key = first_api_key(tmp_path, (tmp_path / "service.log").read_text())
    answer = httpx.post(f"http://127.0.0.1:{port}/console/login", data={"api_key": key},
                        headers={"X-Forwarded-Proto": "https"} if behind_tls else {},
                        timeout=30)
    assert answer.status_code == 303, answer.text
    return answer.headers["set-cookie"]


def _rss_kib(pid: int) -> int:
    """Resident memory of process ``pid`` [KiB]."""
    status = Path(f"/proc/{pid}/status").read_text()
    return int(next(line.split()[1] for line in status.splitlines()
                    if line.startswith("VmRSS:")))


def _answer(sock: socket.socket) -> bytes:
    """One whole answer (its head and ``Content-Length`` bytes of body) read from ``sock``."""
    data = b""
    while b"\r\n\r\n" not in data:
        data += _received(sock)
    head, _, body = data.partition(b"\r\n\r\n")
    length = int(next(line.split(b":")[1] for line in head.split(b"\r\n")
                      if line.lower().startswith(b"content-length:")))
    while len(body) < length:
        body += _received(sock)
    return data


def _received(sock: socket.socket) -> bytes:
    chunk = sock.recv(65536)
    if not chunk:
        raise AssertionError("the service closed the connection within an answer")
    return chunk


def _health_count(port: int) -> float:
    """``GET /health 200`` as one scrape of ``/metrics`` counts it."""
    text = httpx.get(f"http://127.0.0.1:{port}/metrics", timeout=10).text
    for line in text.splitlines():
        if line.startswith("hydrodiag_http_requests_total{") and 'route="/health"' in line \
                and 'status="200"' in line:
            return float(line.rsplit(" ", 1)[1])
    return 0.0


def test_metrics_sum_every_worker(tmp_path: Path) -> None:
    supervisor, port = _serve(tmp_path, HYDRODIAG_FORWARDED_ALLOW_IPS="10.9.8.7")
    try:
        # a proxy's headers are believed from the addresses named only (here another host):
        # this request's X-Forwarded-Proto is not, so its cookie is not marked Secure
        assert "secure" not in _login_cookie(tmp_path, port, behind_tls=True).lower()
        before = _health_count(port)  # the readiness probes do not count; /health is new
        n = 40
        for _ in range(n):  # a new connection each: the kernel spreads them over workers
            assert httpx.get(f"http://127.0.0.1:{port}/health", timeout=10).status_code == 200
        # whichever worker answers a scrape, it reports all 40 (one worker's own counter
        # would read about half, and differ from scrape to scrape)
        assert [_health_count(port) - before for _ in range(6)] == [n] * 6
        # the supervisor is uvicorn's alone (app.supervisor): serve replaced itself after
        # readying the store, so the 450 MB it had imported and loaded are not held by a
        # process that answers no request
        maps = Path(f"/proc/{supervisor.pid}/maps").read_text()
        assert "numpy" not in maps and "sqlalchemy" not in maps and "numba" not in maps
        workers = [p for p in _children(supervisor.pid) if _parent(p) == supervisor.pid
                   and b"spawn_main" in Path(f"/proc/{p}/cmdline").read_bytes()]
        assert len(workers) == 2
        assert 4 * _rss_kib(supervisor.pid) < min(_rss_kib(p) for p in workers)
        # an idle kept-alive connection is closed after HYDRODIAG_KEEP_ALIVE_S, not before
        # (behind a proxy it is set above the proxy's idle timeout)
        kept = socket.create_connection(("127.0.0.1", port))
        health = b"GET /health HTTP/1.1\r\nHost: x\r\n\r\n"
        for pause in (0.0, KEEP_ALIVE_S / 2):
            time.sleep(pause)
            kept.sendall(health)
            assert _answer(kept).startswith(b"HTTP/1.1 200")
        # closed by the service before uvicorn's default 5 s (a timeout raised otherwise)
        kept.settimeout(KEEP_ALIVE_S + 2)
        assert kept.recv(65536) == b""
        kept.close()
        assert len(list((tmp_path / "tmp").glob("hydrodiag-metrics-*/*.db"))) >= 2
        # the workers (and their diagnosis processes) start with at most two malloc
        # arenas: the busy worker of a soak grew +10.5 MiB per 1,000 requests with glibc's
        # default (app.services.heap.limit_arenas)
        started = _children(supervisor.pid)
        assert started and all(b"MALLOC_ARENA_MAX=2" in Path(f"/proc/{p}/environ").read_bytes()
                               .split(b"\0") for p in started if _alive(p))
        # a client uploading a body a byte at a time kept a SIGTERMed service running past
        # 45 s (an SRE pass): open requests are now cut off after CONNECTIONS_GRACE_S
        slow = socket.create_connection(("127.0.0.1", port))
        slow.sendall(b"POST /diagnose HTTP/1.1\r\nHost: x\r\nContent-Type: application/json"
                     b"\r\nContent-Length: 1000\r\n\r\n{")
        time.sleep(0.5)
        supervisor.send_signal(signal.SIGTERM)
        supervisor.wait(timeout=30)  # it waited for ever; 3 s of grace, 5 s for jobs
        slow.close()
    finally:
        if supervisor.poll() is None:
            supervisor.send_signal(signal.SIGTERM)
            supervisor.wait(timeout=60)
    # the workers' value files lived in a folder of their own, removed on a clean stop
    assert not list((tmp_path / "tmp").glob("hydrodiag-metrics-*"))


def test_a_killed_supervisor_takes_its_workers_with_it(tmp_path: Path) -> None:
    # started in a folder with a package of its own named app (a common name): serve
    # replaces itself with `python -m app.supervisor`, which must not import that one
    (tmp_path / "project" / "app").mkdir(parents=True)
    (tmp_path / "project" / "app" / "__init__.py").write_text(
        "raise ImportError('the project\'s own app package, not hydrodiag\'s')\n")
    supervisor, port = _serve(tmp_path, cwd=tmp_path / "project")
    descendants: set[int] = set()
    try:
        # a proxy on this host (the default trust) that terminated TLS: the console's cookie
        # is Secure; asked directly over HTTP, it is not
        assert "secure" in _login_cookie(tmp_path, port, behind_tls=True).lower()
        assert "secure" not in _login_cookie(tmp_path, port, behind_tls=False).lower()
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        # 2 server workers, each with its diagnosis worker (and spawn's resource trackers)
        while len(descendants) < 4 and time.monotonic() < deadline:
            descendants = _children(supervisor.pid)
            time.sleep(0.2)
        assert len(descendants) >= 4
        # a sweep starts a worker's sweep pool: its processes (and their resource tracker)
        # lived on as orphans after a kill -9, ~350 MB each (an operator's pass)
        key = first_api_key(tmp_path, (tmp_path / "service.log").read_text())
        url = f"http://127.0.0.1:{port}"
        job = httpx.post(f"{url}/scenarios", headers={"X-API-Key": key}, json={
            "rig_id": 1, "faults": ["healthy"], "method": "transient",
            "conditions": [{"name": "load", "low": 2100, "high": 4200, "levels": 4}]},
            timeout=60).json()["job_id"]
        while httpx.get(f"{url}/jobs/{job}", headers={"X-API-Key": key},
                        timeout=30).json()["status"] in ("queued", "running"):
            assert time.monotonic() < deadline
            time.sleep(0.5)
        pool = _children(supervisor.pid) - descendants
        assert len(pool) >= 2, pool            # the sweep processes of the worker that ran it
        descendants |= pool
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


def test_the_metrics_folder_of_a_dead_serve_is_removed_at_the_next_start(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # kill -9 of serve left its folder in /tmp; a crash loop piled them up (an operator pass)
    import tempfile

    from app.metrics import MULTIPROCESS_DIR, shared_metrics

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.delenv(MULTIPROCESS_DIR, raising=False)
    dead = subprocess.Popen(["true"])
    dead.wait()
    orphan = tmp_path / f"hydrodiag-metrics-{dead.pid}-abc"
    living = tmp_path / f"hydrodiag-metrics-{os.getpid()}-def"
    other = tmp_path / "hydrodiag-metrics-notapid"
    for folder in (orphan, living, other):
        folder.mkdir()
    with shared_metrics() as folder:
        assert folder.startswith(str(tmp_path / f"hydrodiag-metrics-{os.getpid()}-"))
        assert not orphan.exists() and living.exists() and other.exists()
    assert not os.path.exists(folder)
