"""``make soak``: does ``hydrodiag serve`` grow while it runs a long, mixed workload?

Starts the service with its defaults (embedded SQLite in a fresh data folder, the reference
rig preloaded, one worker per core, the access log on) on a free loopback port and sends it,
one request at a time at ``RATE_PER_S`` (4/s), what a plant sends in a day: stored
``/diagnose`` calls (every record at its own condition and time), steady ``/simulate``
calls and, at their own periods, a transient one exported as CSV or Parquet, a console
login with two pages and a logout, a throttle table and a pump set created, read and
deleted, a measured series imported, read as a record and deleted, a sweep and a
discrepancy check posted as jobs and followed to their end, ``/metrics``, ``/ready``,
trends and history pages.  Every ``SAMPLE_S`` it reads each server process's resident
memory, descriptors and threads, the store and its WAL, the rows of every table, the files
of the metrics folder, the temporary directory and the compile cache, and the log's size
(:mod:`benchmarks.soak_probe`).

It prints a table of those figures over time and, as its last line, one JSON object: each
figure at the start and end and its growth per 1,000 requests, fitted by least squares over
the second half of the samples (after the caches' warm-up) and over all of them.
``SOAK_DURATION_S`` sets the length (600 s; 30 s with ``HYDRODIAG_LIGHT=1``, which leaves
the discrepancy check out and runs the other operations three times as often: a smoke test
of the mixed workload for CI).  It exits 1 when a request failed (a 4xx, a 5xx
other than 503, no answer).
"""

from __future__ import annotations

import io
import json
import os
import random
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pandas as pd

from benchmarks.load_bench import serve
from benchmarks.soak_probe import Sample, sample

LIGHT = os.environ.get("HYDRODIAG_LIGHT") == "1"
DURATION_S = float(os.environ.get("SOAK_DURATION_S", 30 if LIGHT else 600))
RATE_PER_S = 4.0
SAMPLE_S = 10.0 if LIGHT else 30.0
#: periods of the occasional operations [s]
PERIODS_S = {"console": 20.0, "export": 15.0, "tables": 30.0, "series": 30.0, "sweep": 45.0,
             "discrepancy": 150.0, "trends": 60.0}
if LIGHT:  # CI's smoke form: every operation once or twice, the discrepancy check left out
    PERIODS_S = {k: v / 3 for k, v in PERIODS_S.items() if k != "discrepancy"}
SWEEP = {"rig_id": 1, "faults": ["healthy", "worn_spool"],
         "parameters": [{"name": "cylinder.cc", "low": 83e-6, "high": 130e-6, "levels": 3}],
         "conditions": [{"name": "load", "low": 2100.0, "high": 6300.0, "levels": 2}]}
TABLE = {"throttle": "I", "component": "valve", "back_pressure_pa": 2.0e6,
         "temperature_c": 45.0, "source": "soak", "points": [
             {"opening_turns": 0.0, "bypass_flow_m3s": 9.0e-6, "clearance_m": 35e-6},
             {"opening_turns": 1.0, "bypass_flow_m3s": 3.0e-5, "clearance_m": 50e-6},
             {"opening_turns": 2.0, "bypass_flow_m3s": 9.0e-5, "clearance_m": 75e-6}]}
PUMP_SET = {"name": "soak-pump", "kind": "parameters", "pump": "gear pump 14.7 cm³/rev",
            "source": "soak", "rig_id": 1, "quantities": {
                "displacement": {"value": 1.47e-5, "unit": "m^3/rev"},
                "Cs": {"value": 2.1e-9, "unit": "1"}}}
LOADS_N = (2100.0, 4200.0, 6300.0)


@dataclass
class Counts:
    """Requests sent, by outcome."""

    requests: int = 0
    errors: int = 0
    busy: int = 0
    jobs_done: dict[str, int] = field(default_factory=dict)


class Workload:
    """The mixed requests, one at a time, and the jobs they started followed to the end."""

    def __init__(self, http: httpx.Client, counts: Counts) -> None:
        self.http, self.counts = http, counts
        self.rnd = random.Random(7)
        self.bases: list[dict[str, Any]] = []
        self.jobs: dict[str, str] = {}
        self.series: list[int] = []
        self.export = pd.DataFrame()
        self.cycles = b""

    def call(self, method: str, url: str, **kwargs: Any) -> httpx.Response | None:
        self.counts.requests += 1
        try:
            r = self.http.request(method, url, **kwargs)
        except httpx.TransportError:
            self.counts.errors += 1
            return None
        if r.status_code == 503:
            self.counts.busy += 1
        elif r.status_code >= 400:
            self.counts.errors += 1
            print(f"{method} {url}: {r.status_code} {r.text[:200]}", file=sys.stderr)
        return r

    def prepare(self) -> None:
        """Steady readings at a few conditions, a transient export and a discrepancy file."""
        for temperature in (35.0, 45.0, 55.0):
            for load in LOADS_N:
                s = self.http.post("/simulate", json={
                    "rig_id": 1, "method": "steady", "overrides": {"valve.cv": 50e-6},
                    "condition": {"load": load, "oil_temperature": temperature}}).json()["summary"]
                self.bases.append({"t": temperature, "load": load, "readings": {
                    "pump_pressure": s["working.P_pump [Pa]"], "p1": s["working.P1 [Pa]"],
                    "p2": s["working.P2 [Pa]"], "flow_B": s["working.Q_meter_B [m^3/s]"],
                    "flow_C": s["working.Q_meter_C [m^3/s]"],
                    "speed_work": s["working.speed [m/s]"],
                    "speed_return": s["return.speed [m/s]"]}})
        frames = []
        for load in LOADS_N:
            content = self.http.post("/simulate", json={
                "rig_id": 1, "fault": "worn_spool", "condition": {"load": load},
                "sample_rate": 1000, "timeseries": "csv"}).content
            frame = pd.read_csv(io.BytesIO(content), comment="#")
            if load == LOADS_N[1]:
                self.export = frame
            frames.append(frame.assign(record=f"load-{load:.0f}"))
        self.cycles = pd.concat(frames).to_csv(index=False).encode()

    def diagnose(self) -> None:
        base = self.rnd.choice(self.bases)
        n = self.counts.requests
        readings = {k: v * (1 + self.rnd.gauss(0, 0.002)) for k, v in base["readings"].items()}
        stamp = f"2026-{1 + n // 40000 % 12:02d}-{1 + n // 1440 % 28:02d}T" \
                f"{n // 60 % 24:02d}:{n % 60:02d}:{self.rnd.randrange(60):02d}Z"
        self.call("POST", "/diagnose", json={"record": {
            "rig_id": 1, "measured_at": stamp, **readings, "condition": {
                "oil_temperature": base["t"] + self.rnd.uniform(-3, 3),
                "load_force": base["load"] * self.rnd.uniform(0.9, 1.1)}}})

    def steady(self) -> None:
        self.call("POST", "/simulate", json={
            "rig_id": 1, "method": "steady", "overrides": {
                "cylinder.cc": self.rnd.uniform(83e-6, 140e-6)},
            "condition": {"load": self.rnd.uniform(2000, 6500),
                          "oil_temperature": self.rnd.uniform(30, 60)}})

    def exported(self, kind: str) -> None:
        self.call("POST", "/simulate", json={
            "rig_id": 1, "fault": "worn_spool", "sample_rate": 500, "timeseries": kind,
            "condition": {"load": self.rnd.uniform(2000, 6500)}})

    def console(self, key: str) -> None:
        self.call("POST", "/console/login", data={"api_key": key})
        self.call("GET", "/console/rigs/1")
        self.call("GET", "/console/history")
        self.call("POST", "/console/logout")
        self.http.cookies.clear()

    def tables(self) -> None:
        r = self.call("POST", "/rigs/1/calibrations", json=TABLE)
        if r is not None and r.status_code == 201:
            cid = r.json()["id"]
            self.call("GET", f"/rigs/1/calibrations/{cid}")
            self.call("DELETE", f"/rigs/1/calibrations/{cid}")
        r = self.call("POST", "/pump-sets", json=PUMP_SET | {
            "name": f"soak-{self.counts.requests}"})
        if r is not None and r.status_code == 201:
            pid = r.json()["id"]
            self.call("GET", f"/pump-sets/{pid}")
            self.call("DELETE", f"/pump-sets/{pid}")

    def import_series(self) -> None:
        n = self.counts.requests
        pressures = [c for c in self.export.columns if c.endswith("[Pa]")]
        moved = self.export.assign(**{c: self.export[c] * (1 + 1e-7 * n) for c in pressures})
        r = self.call("POST", "/rigs/1/series", data={"name": f"s-{n}"}, files={
            "file": ("run.csv", moved.to_csv(index=False).encode(), "text/csv")})
        if r is not None and r.status_code == 201:
            sid = int(r.json()["items"][0]["id"])
            self.series.append(sid)
            self.call("GET", f"/series/{sid}/record")
        while len(self.series) > 2:
            self.call("DELETE", f"/series/{self.series.pop(0)}")

    def post_job(self, kind: str) -> None:
        if kind == "sweep":
            r = self.call("POST", "/scenarios", json=SWEEP)
        else:
            r = self.call("POST", "/discrepancy", data={"rig_id": "1"},
                          files={"file": ("cycles.csv", self.cycles, "text/csv")})
        if r is not None and r.status_code == 202:
            self.jobs[r.json()["job_id"]] = kind

    def follow_jobs(self) -> None:
        for job_id, kind in list(self.jobs.items()):
            r = self.call("GET", f"/jobs/{job_id}")
            if r is not None and r.status_code == 200 and r.json()["status"] in (
                    "succeeded", "failed", "cancelled"):
                del self.jobs[job_id]
                outcome = f"{kind} {r.json()['status']}"
                self.counts.jobs_done[outcome] = self.counts.jobs_done.get(outcome, 0) + 1


def _slope(xs: list[float], ys: list[float]) -> float | None:
    """Least-squares growth of ``ys`` per 1,000 of ``xs``; ``None`` for fewer than 3 points."""
    if len(xs) < 3 or np.ptp(xs) == 0:
        return None
    return round(float(np.polyfit(np.asarray(xs), np.asarray(ys), 1)[0] * 1000), 3)


def _by_role(values: dict[str, float]) -> dict[str, float]:
    out: dict[str, float] = {}
    for name, v in values.items():
        out[name.split(":")[0]] = out.get(name.split(":")[0], 0.0) + v
    return out


def _figures(s: Sample) -> dict[str, float]:
    f = {f"rss_mb.{k}": v for k, v in _by_role(s.rss_mb).items()}
    f |= {"rss_mb.total": sum(s.rss_mb.values()), "fds.total": sum(s.fds.values()),
          "threads.total": sum(s.threads.values()), "processes": len(s.rss_mb),
          "db_mb": s.db_mb, "wal_mb": s.wal_mb, "metrics_files": s.metrics_files,
          "tmp_entries": s.tmp_entries, "cache_files": s.cache_files, "log_mb": s.log_mb}
    f |= {f"fds.{k}": v for k, v in _by_role(s.fds).items()}  # type: ignore[arg-type]
    f |= {f"fds.kind.{k}": v for k, v in s.fd_kinds.items()}
    f |= {f"threads.{k}": v for k, v in _by_role(s.threads).items()}  # type: ignore[arg-type]
    return f | {f"rows.{k}": v for k, v in s.rows.items()}


ROW = ("{t:>6.0f} {req:>6d} {rss:>8.0f} {worker:>7.0f} {child:>7.0f} {fds:>5.0f} {thr:>5.0f} "
       "{procs:>5.0f} {db:>7.2f} {wal:>6.2f} {jobs:>5.0f} {logouts:>6.0f} {metr:>5.0f} "
       "{tmp:>5.0f} {log:>6.2f}")
HEAD = (f"{'t [s]':>6} {'req':>6} {'RSS MiB':>8} {'worker':>7} {'child':>7} {'fds':>5} "
        f"{'thr':>5} {'procs':>5} {'db MiB':>7} {'WAL':>6} {'jobs':>5} {'logout':>6} "
        f"{'metr':>5} {'tmp':>5} {'logMiB':>6}")


def _row(s: Sample) -> str:
    f = _figures(s)
    return ROW.format(t=s.t, req=s.requests, rss=f["rss_mb.total"],
                      worker=f.get("rss_mb.worker", 0.0), child=f.get("rss_mb.child", 0.0),
                      fds=f["fds.total"], thr=f["threads.total"], procs=f["processes"],
                      db=s.db_mb, wal=s.wal_mb, jobs=s.rows["jobs"],
                      logouts=s.rows["console_logouts"], metr=s.metrics_files,
                      tmp=s.tmp_entries, log=s.log_mb)


def run(data_dir: Path) -> dict[str, Any]:
    """Serve on ``data_dir``, run the workload for :data:`DURATION_S`, sample as it goes."""
    cache = os.environ.get("HYDRODIAG_CACHE_DIR")
    tmp = data_dir / "tmp"  # the service's own temporary directory: its files counted alone
    tmp.mkdir(exist_ok=True)
    counts, samples = Counts(), []
    # with its defaults (the access log on), unlike the load bench's quiet service
    with serve(data_dir, quiet=False, env={"TMPDIR": str(tmp)}) as service:
        process, base, key = service.process, service.base_url, service.key
        metrics_dir = next((tmp / n for n in os.listdir(tmp)
                            if n.startswith(f"hydrodiag-metrics-{process.pid}-")), None)
        probe = dict(root=process.pid, data_dir=data_dir, metrics_dir=metrics_dir, tmp_dir=tmp,
                     cache_dir=Path(cache) if cache else None, log=data_dir / "service.log")
        with httpx.Client(base_url=base, timeout=120, headers={"X-API-Key": key}) as http:
            work = Workload(http, counts)
            work.prepare()
            print(HEAD, flush=True)
            start = time.monotonic()
            due = dict.fromkeys(PERIODS_S, start)
            next_sample, tick = start, 0
            while (now := time.monotonic()) - start < DURATION_S:
                if now >= next_sample:
                    samples.append(sample(now - start, counts.requests, **probe))  # type: ignore[arg-type]
                    print(_row(samples[-1]), flush=True)
                    next_sample += SAMPLE_S
                kind = next((k for k, d in due.items() if now >= d), None)
                if kind is not None:
                    due[kind] = now + PERIODS_S[kind]
                    {"console": lambda: work.console(key),
                     "export": lambda: work.exported(work.rnd.choice(("csv", "parquet"))),
                     "tables": work.tables, "series": work.import_series,
                     "sweep": lambda: work.post_job("sweep"),
                     "discrepancy": lambda: work.post_job("discrepancy"),
                     "trends": lambda: work.call("GET", "/rigs/1/trends")}[kind]()
                else:
                    tick += 1
                    [work.diagnose, work.diagnose, work.diagnose, work.steady,
                     lambda: work.call("GET", "/metrics"), lambda: work.call("GET", "/ready"),
                     lambda: work.call("GET", "/diagnoses", params={"compact": "true"}),
                     work.follow_jobs][tick % 8]()
                time.sleep(max(0.0, 1 / RATE_PER_S - (time.monotonic() - now)))
            deadline = time.monotonic() + 300
            while work.jobs and time.monotonic() < deadline:
                work.follow_jobs()
                time.sleep(1)
            samples.append(sample(time.monotonic() - start, counts.requests, **probe))  # type: ignore[arg-type]
            print(_row(samples[-1]), flush=True)
    return _summary(samples, counts)


def _summary(samples: list[Sample], counts: Counts) -> dict[str, Any]:
    first, last = _figures(samples[0]), _figures(samples[-1])
    late = samples[len(samples) // 2:]
    growth: dict[str, dict[str, float | None]] = {}
    for name in sorted(set(first) | set(last)):
        xs = [float(s.requests) for s in samples]
        ys = [_figures(s).get(name, 0.0) for s in samples]
        xl = [float(s.requests) for s in late]
        yl = [_figures(s).get(name, 0.0) for s in late]
        growth[name] = {"start": round(first.get(name, 0.0), 3),
                        "end": round(last.get(name, 0.0), 3),
                        "per_1000_req": _slope(xs, ys),
                        "per_1000_req_late": _slope(xl, yl)}
    processes = {name: {"rss_mb": [round(samples[0].rss_mb[name], 1),
                                   round(samples[-1].rss_mb[name], 1)],
                        "fds": [samples[0].fds[name], samples[-1].fds[name]],
                        "threads": [samples[0].threads[name], samples[-1].threads[name]]}
                 for name in samples[-1].rss_mb if name in samples[0].rss_mb}
    return {"duration_s": round(samples[-1].t, 1), "requests": counts.requests,
            "errors": counts.errors, "busy_503": counts.busy, "jobs": counts.jobs_done,
            "figures": growth, "processes": processes}


def main() -> None:
    data_dir = Path(os.environ.get("SOAK_DATA_DIR") or tempfile.mkdtemp(prefix="hd-soak-"))
    data_dir.mkdir(parents=True, exist_ok=True)
    result = run(data_dir)
    print(f"\n{result['requests']} requests in {result['duration_s']} s, "
          f"{result['errors']} errors, {result['busy_503']} answered 503; jobs {result['jobs']}")
    print(f"{'figure':<32} {'start':>10} {'end':>10} {'/1000 req':>10} {'late /1000':>10}")
    for name, g in result["figures"].items():
        slopes = [f"{v:>10.3f}" if v is not None else f"{'-':>10}"
                  for v in (g["per_1000_req"], g["per_1000_req_late"])]
        print(f"{name:<32} {g['start']:>10.3f} {g['end']:>10.3f} {' '.join(slopes)}")
    print(f"\n{'process':<20} {'RSS MiB':>15} {'fds':>9} {'threads':>9}   (start -> end)")
    for name, p in result["processes"].items():
        print(f"{name:<20} {p['rss_mb'][0]:>7.1f}->{p['rss_mb'][1]:<7.1f} "
              f"{p['fds'][0]:>4}->{p['fds'][1]:<4} {p['threads'][0]:>4}->{p['threads'][1]:<4}")
    print(json.dumps(result, separators=(",", ":"), allow_nan=False))
    if result["errors"]:
        sys.exit(1)  # every request of the workload is valid: a failed one is a bug


if __name__ == "__main__":
    main()
