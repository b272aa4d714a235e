"""Load benchmark of the service: ``/diagnose`` against ``/health``, a sustained rate, a ramp.

Starts ``hydrodiag serve`` as configured by the environment (by default one server worker
per core, each with one diagnosis process; embedded SQLite in a temporary folder) on a
free loopback port and sends it traffic from this process (127.0.0.1; every request built
as bytes before its phase and sent on raw asyncio streams, :mod:`benchmarks.load_clients`,
so that the load generator takes as little of the 2 cores as it can):

1. **Closed loop** — ``CONCURRENCY`` (4) clients send requests back to back: first
   ``GET /health``, then ``POST /diagnose`` (one stored record each, with the API key),
   ``N_REQUESTS`` of each.  p50/p99 and throughput of both and their ratios: the cost of
   a diagnosis over the cost of the HTTP stack alone, in the same run.  Meanwhile the CPU
   time of the service's server processes, of its diagnosis processes and of this load
   generator is read (``/proc``) and given per request [ms]: unlike latencies on a busy
   machine, it says where the work goes; and the mean timeline of a stored diagnosis
   (:func:`benchmarks.load_timeline.timeline`: where it waits).
2. **Sustained** — stored ``POST /diagnose`` opened at ``RATE`` (200) requests/s for
   ``DURATION_S`` (60 s; 10 s with ``HYDRODIAG_LIGHT=1``) whatever the answers' pace (open
   loop), while ``GET /health`` is probed 20 times a second from a process of its own
   (:mod:`benchmarks.load_probe`: probed from the sending process it measured the client).
   Errors are non-200 answers, transport errors and answers later than 10 s.  Every
   acknowledged diagnosis (a 200 with its id) must be in the store afterwards.
3. **Ramp** — the same open loop at rising rates from 50/s (``RAMP_RPS``, ``RAMP_S`` each;
   light form: three short steps) until p99 passes 100 ms or a request fails; the highest rate
   that held is reported.

Every record is different: readings simulated (``POST /simulate``, steady path) on a grid
of oil temperatures, loads and valve wear, then each record's temperature and load moved
by a random fraction of their instrument uncertainty and every reading given 0.2 % noise,
so no two records share a condition and nothing can be answered from a cache keyed by the
request.  The machine's load average is printed with the figures: timings taken on a busy
machine are only comparable as the ratios of this run.

Targets, reported as met or not: ``/diagnose`` p50 within 3× ``/health`` p50; at 200/s for
the whole span 0 errors, p99 ≤ 100 ms, ``/health`` p99 ≤ 20 ms meanwhile, every
acknowledged diagnosis stored; the highest sustained rate ≥ 300/s.

The last line printed is one JSON object with every figure.
"""

from __future__ import annotations

import asyncio
import json
import os
import random
import resource
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx

from app.cli import first_key_shown
from benchmarks.load_clients import closed_loop, open_loop, request_bytes
from benchmarks.load_timeline import timeline
from benchmarks.soak_probe import process_tree

LIGHT = os.environ.get("HYDRODIAG_LIGHT") == "1"
CONCURRENCY = 4
N_REQUESTS = 150 if LIGHT else 500
RATE = 200.0
DURATION_S = 10.0 if LIGHT else 60.0
RAMP_RPS = (50.0, 100.0, 150.0) if LIGHT else (50.0, 75.0, 100.0, 125.0, 150.0, 200.0, 250.0,
                                               300.0, 400.0)
PROBE_RATE = 20.0
RAMP_S = 4.0 if LIGHT else 15.0
STARTUP_TIMEOUT_S = 240.0
READY_IN_A_ROW = 10
TEMPERATURES_C = (30.0, 40.0, 50.0)
LOADS_N = (1500.0, 2100.0, 2700.0)
WEAR_LEVELS_M = (40e-6, 58e-6)
TEMPERATURE_JITTER_C = 0.5
LOAD_JITTER = 0.005
NOISE = 0.002
P50_TARGET_RATIO = 3.0
P99_TARGET_MS = 100.0
HEALTH_P99_TARGET_MS = 20.0
RATE_TARGET = 300.0


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@dataclass
class Service:
    """A running ``hydrodiag serve``."""

    base_url: str
    key: str
    data_dir: Path
    process: subprocess.Popen[str]


@contextmanager
def serve(data_dir: Path, *, quiet: bool = True, env: dict[str, str] | None = None
          ) -> Iterator[Service]:
    """Start the service on a free loopback port with a fresh store; stop it after.

    ``quiet``: no access log, warnings only (the load bench's); else the service's own
    logging (the soak's, which counts the log's growth).  ``env``: more variables."""
    port = _free_port()
    env = (os.environ | {"HYDRODIAG_DATA_DIR": str(data_dir)}
           | ({"HYDRODIAG_ACCESS_LOG": "false", "HYDRODIAG_LOG_LEVEL": "warning"} if quiet
              else {}) | (env or {}))
    log = (data_dir / "service.log").open("w")
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
        env=env, stdout=subprocess.PIPE, stderr=log, text=True,
    )
    try:
        assert process.stdout is not None
        key = ""
        for line in process.stdout:
            if (shown := first_key_shown(line)) is not None:
                key = shown
                break
        if not key:
            raise RuntimeError(f"the service printed no API key (see {data_dir}/service.log)")
        base_url = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        ready = 0  # several in a row, on new connections: every worker is warm
        while ready < READY_IN_A_ROW:
            try:
                ok = httpx.get(f"{base_url}/ready", timeout=5).status_code == 200
            except httpx.TransportError:
                ok = False
            ready = ready + 1 if ok else 0
            if process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"the service did not start (see {data_dir}/service.log)")
            time.sleep(0.05 if ok else 0.2)
        yield Service(base_url, key, data_dir, process)
    finally:
        process.terminate()
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:  # an overloaded server still draining its queue
            process.kill()
            process.wait(timeout=15)
        log.close()


def _base_records(service: Service) -> list[dict[str, Any]]:
    """Simulated readings on a grid of oil temperature × load × valve wear."""
    records = []
    with httpx.Client(base_url=service.base_url, timeout=60,
                      headers={"X-API-Key": service.key}) as http:
        for temperature in TEMPERATURES_C:
            for load in LOADS_N:
                for cv in WEAR_LEVELS_M:
                    response = http.post("/simulate", json={
                        "rig_id": 1, "overrides": {"valve.cv": cv}, "method": "steady",
                        "condition": {"load": load, "oil_temperature": temperature}})
                    response.raise_for_status()
                    s = response.json()["summary"]
                    records.append({"condition": {"oil_temperature": temperature,
                                                  "load_force": load}, "readings": {
                        "pump_pressure": s["working.P_pump [Pa]"], "p1": s["working.P1 [Pa]"],
                        "p2": s["working.P2 [Pa]"], "flow_B": s["working.Q_meter_B [m^3/s]"],
                        "flow_C": s["working.Q_meter_C [m^3/s]"],
                        "speed_work": s["working.speed [m/s]"],
                        "speed_return": s["return.speed [m/s]"]}})
    return records


class Bodies:
    """Endless distinct /diagnose bodies: a grid point, its condition moved a little, noisy
    readings, a new time."""

    def __init__(self, records: list[dict[str, Any]], seed: int = 1) -> None:
        self._records = records
        self._random = random.Random(seed)
        self._count = 0

    def __call__(self) -> dict[str, Any]:
        self._count += 1
        rnd = self._random
        base = self._records[self._count % len(self._records)]
        readings = {k: v * (1.0 + rnd.gauss(0.0, NOISE)) for k, v in base["readings"].items()}
        condition = {
            "oil_temperature": base["condition"]["oil_temperature"]
            + rnd.uniform(-TEMPERATURE_JITTER_C, TEMPERATURE_JITTER_C),
            "load_force": base["condition"]["load_force"]
            * (1.0 + rnd.uniform(-LOAD_JITTER, LOAD_JITTER))}
        minute, second = divmod(self._count, 60)
        stamp = f"2026-06-{1 + (minute // 1440) % 28:02d}T{(minute // 60) % 24:02d}:" \
                f"{minute % 60:02d}:{second:02d}Z"
        return {"record": {"rig_id": 1, "measured_at": stamp, "condition": condition,
                           **readings}}


def _stored_ids(data_dir: Path) -> set[int]:
    with sqlite3.connect(data_dir / "hydrodiag.db") as connection:
        return {int(row[0]) for row in connection.execute("SELECT id FROM diagnoses")}


def _acknowledged_ids(bodies: list[bytes]) -> list[int]:
    return [int(d["id"]) for body in bodies for d in json.loads(body)["diagnoses"]]


def _cpu_s(pid: int) -> float:
    """CPU time (user + system) of process ``pid`` so far [s]; 0 when it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text(encoding="utf-8").rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _is_diagnosis_process(pid: int) -> bool:
    """A leaf process started by ``multiprocessing`` spawn: a diagnosis worker."""
    try:
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
        children = Path(f"/proc/{pid}/task/{pid}/children").read_text(encoding="utf-8").split()
    except OSError:
        return False
    return b"spawn_main" in cmdline and not children


@contextmanager
def cpu_meter(root: int, figures: dict[str, Any]) -> Iterator[None]:
    """CPU time spent meanwhile by the service's server processes, by its diagnosis
    processes, and by this load generator (``*_cpu_s`` in ``figures``) [s]."""
    pids = process_tree(root)
    before = {pid: _cpu_s(pid) for pid in pids}
    own = resource.getrusage(resource.RUSAGE_SELF)
    yield
    after = {pid: _cpu_s(pid) for pid in pids}
    mine = resource.getrusage(resource.RUSAGE_SELF)
    diagnosis = {pid for pid in pids if _is_diagnosis_process(pid)}
    spent = {pid: after[pid] - before[pid] for pid in pids}
    figures["server_cpu_s"] = sum(v for pid, v in spent.items() if pid not in diagnosis)
    figures["diagnosis_cpu_s"] = sum(v for pid, v in spent.items() if pid in diagnosis)
    figures["client_cpu_s"] = (mine.ru_utime + mine.ru_stime) - (own.ru_utime + own.ru_stime)


def _per_request_ms(figures: dict[str, Any]) -> dict[str, float]:
    """CPU per request [ms] of each part, from :func:`cpu_meter`'s figures."""
    return {f"{part}_cpu_ms_per_request": 1e3 * figures[f"{part}_cpu_s"] / figures["n"]
            for part in ("server", "diagnosis", "client")}


def _sustained(base_url: str, requests: list[bytes], rate: float, duration: float
               ) -> dict[str, Any]:
    """The open loop, with ``/health`` probed from a process of its own meanwhile."""
    prober = subprocess.Popen(
        [sys.executable, "-m", "benchmarks.load_probe", base_url, str(duration),
         str(PROBE_RATE)], stdout=subprocess.PIPE, text=True)
    try:
        figures = asyncio.run(open_loop(base_url, requests, rate, duration))
        out, _ = prober.communicate(timeout=duration + 60.0)
    finally:
        if prober.poll() is None:
            prober.kill()
    figures["probe"] = json.loads(out.strip().splitlines()[-1])
    return figures


def _holds(figures: dict[str, Any]) -> bool:
    return bool(figures["errors"] == 0 and figures["p99_ms"] <= P99_TARGET_MS)


def run() -> dict[str, Any]:
    """Run the three phases against a fresh service; return every figure."""
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="hydrodiag-load-") as folder, \
            serve(Path(folder)) as service:
        bodies = Bodies(_base_records(service))
        headers = {"X-API-Key": service.key}
        health = request_bytes(service.base_url, "GET", "/health")

        def diagnoses(n: int) -> list[bytes]:  # built before the phase that sends them
            return [request_bytes(service.base_url, "POST", "/diagnose", bodies(), headers)
                    for _ in range(n)]

        asyncio.run(closed_loop(service.base_url, [health] * 50, CONCURRENCY))  # warm-up
        asyncio.run(closed_loop(service.base_url, diagnoses(30), CONCURRENCY))
        health_stats: dict[str, Any] = {}
        with cpu_meter(service.process.pid, health_stats):
            health_stats |= asyncio.run(closed_loop(service.base_url, [health] * N_REQUESTS,
                                                    CONCURRENCY))
        diagnose_stats: dict[str, Any] = {}
        requests = diagnoses(N_REQUESTS)
        with cpu_meter(service.process.pid, diagnose_stats):
            diagnose_stats |= asyncio.run(closed_loop(service.base_url, requests,
                                                      CONCURRENCY))
        stages = timeline(service.base_url)
        health_stats |= _per_request_ms(health_stats)
        diagnose_stats |= _per_request_ms(diagnose_stats)
        sustained = _sustained(service.base_url, diagnoses(round(RATE * DURATION_S)), RATE,
                               DURATION_S)
        ramp = []
        for rate in RAMP_RPS:
            step = _sustained(service.base_url, diagnoses(round(rate * RAMP_S)), rate, RAMP_S)
            ramp.append(step)
            if not _holds(step):
                break
        # an acknowledged diagnosis was stored before its answer was sent
        acknowledged = _acknowledged_ids(sustained.pop("acknowledged"))
        for step in ramp:
            acknowledged += _acknowledged_ids(step.pop("acknowledged"))
        stored = _stored_ids(service.data_dir)
    missing = [i for i in acknowledged if i not in stored]
    ratio_p50 = diagnose_stats["p50_ms"] / health_stats["p50_ms"]
    held = [s["target_rps"] for s in ramp if _holds(s)]
    best = max(held + ([RATE] if _holds(sustained) else []), default=0.0)
    probe = sustained["probe"]
    return {
        "light": LIGHT, "cores": os.cpu_count(), "concurrency": CONCURRENCY,
        "workers": os.environ.get("HYDRODIAG_WORKERS", "default (one per core)"),
        "load_average_before": [round(x, 2) for x in load_before],
        "load_average_after": [round(x, 2) for x in os.getloadavg()],
        "health": health_stats, "diagnose": diagnose_stats, "timeline_ms": stages,
        "ratio_p50": ratio_p50, "ratio_p99": diagnose_stats["p99_ms"] / health_stats["p99_ms"],
        "ratio_throughput": health_stats["throughput_rps"] / diagnose_stats["throughput_rps"],
        "sustained": sustained,
        "ramp": ramp, "highest_sustained_rps": best,
        "acknowledged": len(acknowledged), "acknowledged_missing": len(missing),
        "targets": {
            "diagnose_p50_within_3x_health_p50": bool(ratio_p50 <= P50_TARGET_RATIO),
            f"no_errors_at_{RATE:g}rps_for_{DURATION_S:g}s": bool(sustained["errors"] == 0),
            f"p99_within_{P99_TARGET_MS:g}ms_at_{RATE:g}rps": bool(
                sustained["p99_ms"] <= P99_TARGET_MS),
            f"health_p99_within_{HEALTH_P99_TARGET_MS:g}ms_under_load": bool(
                probe["errors"] == 0 and probe["p99_ms"] <= HEALTH_P99_TARGET_MS),
            "every_acknowledged_diagnosis_stored": not missing,
            f"sustained_rate_at_least_{RATE_TARGET:g}rps": bool(best >= RATE_TARGET),
        },
    }


def _table(result: dict[str, Any]) -> str:
    h, d, s = result["health"], result["diagnose"], result["sustained"]

    def open_row(name: str, f: dict[str, Any]) -> tuple[Any, ...]:
        return (name, f["sent"], f["errors"], f["p50_ms"], f["p99_ms"], f["throughput_rps"])

    rows: list[tuple[Any, ...]] = [
        ("phase", "requests", "errors", "p50 [ms]", "p99 [ms]", "throughput [req/s]"),
        (f"GET /health ({CONCURRENCY} clients)", h["n"], h["errors"], h["p50_ms"], h["p99_ms"],
         h["throughput_rps"]),
        (f"POST /diagnose ({CONCURRENCY} clients)", d["n"], d["errors"], d["p50_ms"],
         d["p99_ms"], d["throughput_rps"]),
        ("ratio diagnose/health", "", "", result["ratio_p50"], result["ratio_p99"],
         1.0 / result["ratio_throughput"]),
        open_row(f"POST /diagnose open loop {s['target_rps']:g}/s × {s['duration_s']:g} s", s),
        ("  GET /health meanwhile (20/s)", s["probe"]["n"], s["probe"]["errors"],
         s["probe"]["p50_ms"], s["probe"]["p99_ms"], s["probe"]["throughput_rps"]),
    ]
    for step in result["ramp"]:
        rows.append(open_row(f"ramp {step['target_rps']:g}/s × {step['duration_s']:g} s", step))
        rows.append(("  GET /health meanwhile", step["probe"]["n"], step["probe"]["errors"],
                     step["probe"]["p50_ms"], step["probe"]["p99_ms"],
                     step["probe"]["throughput_rps"]))
    lines = []
    for row in rows:
        cells = [f"{c:.3g}" if isinstance(c, float) else str(c) for c in row]
        lines.append(f"{cells[0]:<44}" + "".join(f"{c:>20}" for c in cells[1:]))
    for name, met in result["targets"].items():
        lines.append(f"target {name}: {'met' if met else 'NOT met'}")
    lines.append(f"sustained: peak {s['peak_in_flight']:.0f} in flight on "
                 f"{s['connections']:.0f} connections opened, failures "
                 f"{s['failures'] or 'none'}; {result['acknowledged']} acknowledged "
                 f"diagnoses, {result['acknowledged_missing']} of them missing from the store; "
                 f"highest sustained rate {result['highest_sustained_rps']:g}/s")
    lines.append("CPU per request [ms] (4 clients, closed loop): "
                 + "; ".join(f"{name} server {f['server_cpu_ms_per_request']:.2f}, diagnosis "
                             f"processes {f['diagnosis_cpu_ms_per_request']:.2f}, load "
                             f"generator {f['client_cpu_ms_per_request']:.2f}"
                             for name, f in (("/health", h), ("/diagnose", d))))
    lines.append("timeline of a stored /diagnose, mean [ms] (one server process, closed loops): "
                 + ", ".join(f"{k} {v:.2f}" for k, v in result["timeline_ms"].items()))
    lines.append(f"load average before {result['load_average_before']}, after "
                 f"{result['load_average_after']} on {result['cores']} cores")
    return "\n".join(lines)


def main() -> None:
    """Run the benchmark, print the table, then the JSON object as the last line."""
    result = run()
    print(_table(result))
    print(json.dumps(result))


if __name__ == "__main__":
    main()
