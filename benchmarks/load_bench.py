"""Load benchmark of the service: ``/diagnose`` against ``/health``, then a sustained rate.

Starts ``hydrodiag serve`` (uvicorn, embedded SQLite in a temporary folder) on a free
loopback port and sends it traffic from this process (asyncio + httpx, 127.0.0.1 only):

1. **Closed loop** — ``CONCURRENCY`` clients send requests back to back: first
   ``GET /health``, then ``POST /diagnose`` (one stored record each, with the API key),
   ``N_REQUESTS`` of each.  Latency p50/p99 and throughput of both, and their ratios: the
   cost of a diagnosis over the cost of the HTTP stack alone, on the same machine in the
   same run.
2. **Sustained** — ``POST /diagnose`` opened at ``RATE`` requests/s for ``DURATION_S``
   seconds (10 s with ``HYDRODIAG_LIGHT=1``), whatever the answers' pace (open loop);
   errors are non-200 answers, transport errors and answers later than ``TIMEOUT_S``
   (queueing for a connection included).  Every answered request must be in the store.

Every record is different: simulated readings of a valve at one of several wear levels
(``POST /simulate``, steady path) with 0.2 % random noise on each reading, so nothing can
be answered from a cache keyed by the request.  The service runs as configured by the
environment (``HYDRODIAG_WORKERS=2`` gives it two processes).  Targets, reported as met or not:
``/diagnose`` p50 within 3× of ``/health`` p50; no errors at 200 requests/s for 60 s.

The last line printed is one JSON object with every figure.
"""

from __future__ import annotations

import asyncio
import json
import os
import random
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import numpy as np

LIGHT = os.environ.get("HYDRODIAG_LIGHT") == "1"
CONCURRENCY = 4
N_REQUESTS = 150 if LIGHT else 500
RATE = 200.0
DURATION_S = 10.0 if LIGHT else 60.0
TIMEOUT_S = 10.0
CLIENT_CONNECTIONS = 128
STARTUP_TIMEOUT_S = 120.0
WEAR_LEVELS_M = (34e-6, 40e-6, 46e-6, 52e-6, 58e-6, 64e-6)
NOISE = 0.002
P50_TARGET_RATIO = 3.0


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
def serve(data_dir: Path) -> Iterator[Service]:
    """Start the service on a free loopback port with a fresh store; stop it after."""
    port = _free_port()
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(data_dir), "HYDRODIAG_ACCESS_LOG": "false",
                        "HYDRODIAG_LOG_LEVEL": "warning"}
    log = (data_dir / "service.log").open("w")
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
        env=env, stdout=subprocess.PIPE, stderr=log, text=True,
    )
    try:
        assert process.stdout is not None
        key = ""
        for line in process.stdout:
            if line.startswith("API key: "):
                key = line.split(": ", 1)[1].strip()
                break
        if not key:
            raise RuntimeError(f"the service printed no API key (see {data_dir}/service.log)")
        base_url = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while True:
            try:
                if httpx.get(f"{base_url}/health", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"the service did not start (see {data_dir}/service.log)")
            time.sleep(0.1)
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
    """One simulated record per wear level of the valve (readings as the rig gives them)."""
    records = []
    for cv in WEAR_LEVELS_M:
        response = httpx.post(f"{service.base_url}/simulate", timeout=60,
                              headers={"X-API-Key": service.key}, json={
            "rig_id": 1, "overrides": {"valve.cv": cv}, "method": "steady",
            "condition": {"load": 2100.0, "oil_temperature": 40.0}})
        response.raise_for_status()
        s = response.json()["summary"]
        records.append({
            "pump_pressure": s["working.P_pump [Pa]"], "p1": s["working.P1 [Pa]"],
            "p2": s["working.P2 [Pa]"], "flow_B": s["working.Q_meter_B [m^3/s]"],
            "flow_C": s["working.Q_meter_C [m^3/s]"], "speed_work": s["working.speed [m/s]"],
            "speed_return": s["return.speed [m/s]"],
        })
    return records


class Bodies:
    """Endless distinct /diagnose bodies: a wear level, noisy readings, a new time."""

    def __init__(self, records: list[dict[str, Any]], seed: int = 1) -> None:
        self._records = records
        self._random = random.Random(seed)
        self._count = 0

    def __call__(self) -> dict[str, Any]:
        self._count += 1
        base = self._records[self._count % len(self._records)]
        readings = {k: v * (1.0 + self._random.gauss(0.0, NOISE)) for k, v in base.items()}
        minute, second = divmod(self._count, 60)
        stamp = f"2026-06-{1 + (minute // 1440) % 28:02d}T{(minute // 60) % 24:02d}:" \
                f"{minute % 60:02d}:{second:02d}Z"
        return {"record": {"rig_id": 1, "measured_at": stamp,
                           "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
                           **readings}}


def _stats(latencies: list[float], errors: int, elapsed: float) -> dict[str, float]:
    lat = np.asarray(latencies) * 1e3
    return {
        "n": float(len(latencies) + errors), "errors": float(errors),
        "p50_ms": float(np.percentile(lat, 50)) if lat.size else float("nan"),
        "p99_ms": float(np.percentile(lat, 99)) if lat.size else float("nan"),
        "throughput_rps": len(latencies) / elapsed if elapsed > 0 else float("nan"),
    }


Send = Callable[[httpx.AsyncClient], Awaitable[httpx.Response]]


async def closed_loop(base_url: str, send: Send, n: int, concurrency: int) -> dict[str, float]:
    """``concurrency`` clients send ``n`` requests in all, each after the previous answer."""
    latencies: list[float] = []
    errors = 0
    remaining = n

    async def client(http: httpx.AsyncClient) -> None:
        nonlocal remaining, errors
        while remaining > 0:
            remaining -= 1
            start = time.perf_counter()
            try:
                response = await send(http)
                ok = response.status_code == 200
            except httpx.HTTPError:
                ok = False
            if ok:
                latencies.append(time.perf_counter() - start)
            else:
                errors += 1

    limits = httpx.Limits(max_connections=concurrency, max_keepalive_connections=concurrency)
    async with httpx.AsyncClient(base_url=base_url, timeout=TIMEOUT_S, limits=limits) as http:
        start = time.perf_counter()
        await asyncio.gather(*(client(http) for _ in range(concurrency)))
        elapsed = time.perf_counter() - start
    return _stats(latencies, errors, elapsed)


async def open_loop(base_url: str, send: Send, rate: float, duration: float) -> dict[str, Any]:
    """Open a request every 1/``rate`` s for ``duration`` s, whatever the answers' pace."""
    latencies: list[float] = []
    failures: dict[str, int] = {}
    in_flight = peak = 0

    slots = asyncio.Semaphore(CLIENT_CONNECTIONS)

    async def exchange(http: httpx.AsyncClient) -> httpx.Response:
        async with slots:  # O(1) queueing here; httpcore's pool is slow with long queues
            return await send(http)

    async def one(http: httpx.AsyncClient) -> None:
        nonlocal in_flight, peak
        in_flight += 1
        peak = max(peak, in_flight)
        start = time.perf_counter()
        try:  # one deadline for the whole exchange, waiting for a connection included
            response = await asyncio.wait_for(exchange(http), TIMEOUT_S)
            reason = None if response.status_code == 200 else f"HTTP {response.status_code}"
        except (TimeoutError, httpx.TimeoutException):
            reason = "timeout"
        except httpx.HTTPError as exc:
            reason = type(exc).__name__
        in_flight -= 1
        if reason is None:
            latencies.append(time.perf_counter() - start)
        else:
            failures[reason] = failures.get(reason, 0) + 1

    total = round(rate * duration)
    limits = httpx.Limits(max_connections=CLIENT_CONNECTIONS,
                          max_keepalive_connections=CLIENT_CONNECTIONS)
    async with httpx.AsyncClient(base_url=base_url, timeout=TIMEOUT_S, limits=limits) as http:
        start = time.perf_counter()
        tasks = []
        for i in range(total):
            delay = start + i / rate - time.perf_counter()
            if delay > 0:
                await asyncio.sleep(delay)
            tasks.append(asyncio.create_task(one(http)))
        sending = time.perf_counter() - start
        await asyncio.gather(*tasks)
        elapsed = time.perf_counter() - start
    stats = _stats(latencies, sum(failures.values()), elapsed)
    return stats | {"target_rps": rate, "duration_s": duration, "sent": float(total),
                    "send_rps": total / sending if sending > 0 else float("nan"),
                    "peak_in_flight": float(peak), "failures": failures}


def _stored_diagnoses(data_dir: Path) -> int:
    with sqlite3.connect(data_dir / "hydrodiag.db") as connection:
        return int(connection.execute("SELECT count(*) FROM diagnoses").fetchone()[0])


def run() -> dict[str, Any]:
    """Run both phases against a fresh service; return every figure."""
    with tempfile.TemporaryDirectory(prefix="hydrodiag-load-") as folder, \
            serve(Path(folder)) as service:
        bodies = Bodies(_base_records(service))
        headers = {"X-API-Key": service.key}

        async def health(http: httpx.AsyncClient) -> httpx.Response:
            return await http.get("/health")

        async def diagnose(http: httpx.AsyncClient) -> httpx.Response:
            return await http.post("/diagnose", json=bodies(), headers=headers)

        asyncio.run(closed_loop(service.base_url, health, 50, CONCURRENCY))  # warm-up
        asyncio.run(closed_loop(service.base_url, diagnose, 30, CONCURRENCY))
        stored_before = _stored_diagnoses(service.data_dir)
        health_stats = asyncio.run(closed_loop(service.base_url, health, N_REQUESTS,
                                               CONCURRENCY))
        diagnose_stats = asyncio.run(closed_loop(service.base_url, diagnose, N_REQUESTS,
                                                 CONCURRENCY))
        sustained = asyncio.run(open_loop(service.base_url, diagnose, RATE, DURATION_S))
        # an answered request was stored before its answer; requests the client gave up on
        # may still be stored by a server working through its queue
        stored = _stored_diagnoses(service.data_dir) - stored_before
    ok_total = diagnose_stats["n"] - diagnose_stats["errors"] + sustained["n"] - \
        sustained["errors"]
    ratio_p50 = diagnose_stats["p50_ms"] / health_stats["p50_ms"]
    return {
        "light": LIGHT, "cores": os.cpu_count(), "concurrency": CONCURRENCY,
        "health": health_stats, "diagnose": diagnose_stats,
        "ratio_p50": ratio_p50, "ratio_p99": diagnose_stats["p99_ms"] / health_stats["p99_ms"],
        "ratio_throughput": health_stats["throughput_rps"] / diagnose_stats["throughput_rps"],
        "sustained": sustained,
        "stored_diagnoses": stored, "every_success_stored": stored >= round(ok_total),
        "targets": {
            "diagnose_p50_within_3x_health_p50": bool(ratio_p50 <= P50_TARGET_RATIO),
            f"no_errors_at_{RATE:g}rps_for_{DURATION_S:g}s": bool(sustained["errors"] == 0),
        },
    }


def _table(result: dict[str, Any]) -> str:
    h, d, s = result["health"], result["diagnose"], result["sustained"]
    rows = [
        ("phase", "requests", "errors", "p50 [ms]", "p99 [ms]", "throughput [req/s]"),
        (f"GET /health ({CONCURRENCY} clients)", h["n"], h["errors"], h["p50_ms"], h["p99_ms"],
         h["throughput_rps"]),
        (f"POST /diagnose ({CONCURRENCY} clients)", d["n"], d["errors"], d["p50_ms"],
         d["p99_ms"], d["throughput_rps"]),
        ("ratio diagnose/health", "", "", result["ratio_p50"], result["ratio_p99"],
         1.0 / result["ratio_throughput"]),
        (f"POST /diagnose open loop {s['target_rps']:g}/s × {s['duration_s']:g} s", s["sent"],
         s["errors"], s["p50_ms"], s["p99_ms"], s["throughput_rps"]),
    ]
    lines = []
    for row in rows:
        cells = [f"{c:.3g}" if isinstance(c, float) else str(c) for c in row]
        lines.append(f"{cells[0]:<44}" + "".join(f"{c:>20}" for c in cells[1:]))
    for name, met in result["targets"].items():
        lines.append(f"target {name}: {'met' if met else 'NOT met'}")
    lines.append(f"sustained: peak {s['peak_in_flight']:.0f} in flight, failures "
                 f"{s['failures'] or 'none'}; {result['stored_diagnoses']} diagnoses stored, "
                 f"{'every' if result['every_success_stored'] else 'NOT every'} answered one "
                 "among them")
    return "\n".join(lines)


def main() -> None:
    """Run the benchmark, print the table, then the JSON object as the last line."""
    result = run()
    print(_table(result))
    print(json.dumps(result))


if __name__ == "__main__":
    main()
