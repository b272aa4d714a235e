"""Read paths of a long history: pages, trends and a stored diagnosis at 1,000-100,000
stored diagnoses of one rig.

Run by ``make history-bench``.  A rig diagnosed every 5 minutes stores 100,000 diagnoses in
under a year.  For each size a fresh SQLite store gets the reference rig, ``N_REAL``
records of a valve wearing from 34 to 60 µm simulated (steady path) and diagnosed for real,
and then each stored row (record, result, estimates) repeated at further times, 5 minutes
apart, in batches written straight to the tables — as ``make console-bench`` fills its
store, only faster (a diagnosis a row would take hours at 100,000).  Each read is then
requested in process (``fastapi.testclient``: the whole ASGI stack, no network)
``REPEATS`` times after one warm-up; its median is its time, also given as a ratio to
``GET /health``, the baseline measured in the same run, and as its growth from the
smallest to the largest size (1 for a read that does not depend on the history's length,
about the size ratio for one that reads it all).  Target: a page of the history (API or
console) ≤ 300 ms at every size, as ``make console-bench`` asks of every console page; the
trends, which fit every point, are reported against the same figure.

``HYDRODIAG_LIGHT=1``: 1,000 and 10,000 diagnoses, 3 repeats.
``HYDRODIAG_BENCH_POSTGRES_URL=postgresql+psycopg://USER@HOST:PORT/DB``: the stores on that
PostgreSQL server instead, a new database for each size (its user may create databases;
each is dropped after).  Last line: one JSON object.
"""

from __future__ import annotations

import json
import os
import statistics
import tempfile
import time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

LIGHT = os.environ.get("HYDRODIAG_LIGHT") == "1"
POSTGRES = os.environ.get("HYDRODIAG_BENCH_POSTGRES_URL") or None
SIZES = (1_000, 10_000) if LIGHT else (1_000, 10_000, 100_000)
N_REAL = 5
REPEATS = 3 if LIGHT else 5
TARGET_MS = 300.0
SPACING = timedelta(minutes=5)
START = datetime(2025, 1, 1, tzinfo=UTC)
#: rows written per transaction while filling [-]
BATCH = 5_000

#: name → (URL template, a page of the history?)
READS: dict[str, tuple[str, bool]] = {
    "GET /diagnoses (first page)": ("/diagnoses?limit=50", True),
    "GET /diagnoses rig (first page)": ("/diagnoses?rig_id=1&limit=50", True),
    "GET /diagnoses rig, component": ("/diagnoses?rig_id=1&component=valve&limit=50", True),
    "GET /diagnoses rig (last page)": ("/diagnoses?rig_id=1&limit=50&offset={deep}", True),
    "GET /diagnoses after_id (cursor)": ("/diagnoses?after_id={cursor}&limit=50", True),
    "GET /measurements rig (first page)": ("/measurements?rig_id=1&limit=50", True),
    "GET /diagnoses/{id}": ("/diagnoses/{last}", False),
    "console history (first page)": ("/console/history?rig=1", True),
    "console history (last page)": ("/console/history?rig=1&page={last_page}", True),
    "GET /rigs/1/trends?component=valve": ("/rigs/1/trends?component=valve", False),
    "GET /rigs/1/trends": ("/rigs/1/trends", False),
    "console trends": ("/console/trends?rig=1", False),
}
STORED = "POST /diagnose (stored)"


def _fill(app: Any, real: list[int], size: int) -> tuple[int, dict[str, Any]]:
    """Repeat the real diagnoses' rows up to ``size`` diagnoses; the last diagnosis's id
    and a stored record to post again at a new time."""
    from sqlalchemy import func, insert, select, text

    from app.db.models import Diagnosis, DiagnosisEstimate, DiagnosisRecord, Measurement

    with app.state.sessions() as session:
        rows = [session.get(Diagnosis, i) for i in real]
        template = [(r.measurement.record, r.result, r.component, r.probability,
                     r.rig_version_id,
                     [(e.component, e.probability, e.clearance_m, e.slip_coefficient, e.low,
                       e.high) for e in r.estimates]) for r in rows if r is not None]
        measurement_id = int(session.scalar(select(func.max(Measurement.id))) or 0)
        diagnosis_id = int(session.scalar(select(func.max(Diagnosis.id))) or 0)
        estimate_id = int(session.scalar(select(func.max(DiagnosisEstimate.id))) or 0)
        for first in range(N_REAL, size, BATCH):
            records, diagnoses, links, estimates = [], [], [], []
            for n in range(first, min(size, first + BATCH)):
                record, result, component, probability, version, rows_of = template[
                    n % N_REAL]
                at = START + SPACING * n
                measurement_id += 1
                diagnosis_id += 1
                records.append({"id": measurement_id, "rig_id": 1, "measured_at": at,
                                "record": dict(record) | {"measured_at": at.isoformat()},
                                "created_at": at})
                diagnoses.append({"id": diagnosis_id, "measurement_id": measurement_id,
                                  "rig_version_id": version, "component": component,
                                  "probability": probability, "result": result,
                                  "created_at": at, "superseded_by": None})
                links.append({"diagnosis_id": diagnosis_id, "measurement_id": measurement_id})
                for c, p, clearance, slip, low, high in rows_of:
                    estimate_id += 1
                    estimates.append({"id": estimate_id, "diagnosis_id": diagnosis_id,
                                      "component": c, "probability": p,
                                      "clearance_m": clearance, "slip_coefficient": slip,
                                      "low": low, "high": high})
            session.execute(insert(Measurement), records)
            session.execute(insert(Diagnosis), diagnoses)
            session.execute(insert(DiagnosisRecord), links)
            session.execute(insert(DiagnosisEstimate), estimates)
            session.commit()
        if session.get_bind().dialect.name == "postgresql":   # ids written, not drawn
            for table in ("measurements", "diagnoses", "diagnosis_estimates"):
                session.execute(text(f"SELECT setval(pg_get_serial_sequence('{table}', 'id'), "
                                     f"(SELECT max(id) FROM {table}))"))
            session.commit()
        return diagnosis_id, dict(template[0][0])


def _median_ms(client: Any, method: str, url: str, body: Any = None) -> float:
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        response = client.request(method, url, json=body)
        times.append((time.perf_counter() - t0) * 1e3)
        assert response.status_code == 200, (url, response.status_code, response.text[-300:])
    return statistics.median(times)


@contextmanager
def _store(folder: str, size: int) -> Iterator[tuple[str | None, Callable[[], float]]]:
    """The database URL of a fresh store (``None``: SQLite in ``folder``) and a function
    that gives its size [MiB]."""
    if POSTGRES is None:
        yield None, lambda: sum(p.stat().st_size for p in Path(folder).glob("*.db*")) / 2**20
        return
    from sqlalchemy import create_engine, text
    from sqlalchemy.engine import make_url

    name = f"history_bench_{size}_{os.getpid()}"
    server = create_engine(make_url(POSTGRES), isolation_level="AUTOCOMMIT")
    try:
        with server.connect() as connection:
            connection.execute(text(f'CREATE DATABASE "{name}"'))

        def mib() -> float:
            with server.connect() as connection:
                return float(connection.execute(text(
                    "SELECT pg_database_size(:name)"), {"name": name}).scalar_one()) / 2**20
        yield make_url(POSTGRES).set(database=name).render_as_string(hide_password=False), mib
    finally:
        with server.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        server.dispose()


def _one_size(size: int) -> dict[str, Any]:
    from fastapi.testclient import TestClient

    from app.console.views import HISTORY_PAGE
    from app.main import create_app
    from app.services.keys import create_api_key
    from app.settings import Settings
    from benchmarks.wearing_valve import diagnose_wearing_valve

    with tempfile.TemporaryDirectory(prefix="hydrodiag-history-bench-") as folder, \
            _store(folder, size) as (url, store_mib):
        app = create_app(Settings(data_dir=Path(folder), database_url=url))
        with TestClient(app) as client:
            with app.state.sessions() as session:
                key = create_api_key(session, "history-bench")[1]
            client.headers["X-API-Key"] = key
            t0 = time.perf_counter()
            real = diagnose_wearing_valve(client, [START + SPACING * i for i in range(N_REAL)])
            last, record = _fill(app, real, size)
            fill_s = time.perf_counter() - t0
            mib = store_mib()
            assert client.post("/console/login", data={"api_key": key, "next": ""},
                               follow_redirects=False).status_code == 303
            values = {"deep": max(size - 50, 0), "cursor": max(last - 50, 0), "last": last,
                      "last_page": -(-size // HISTORY_PAGE)}
            client.get("/health")
            reads = {"GET /health": _median_ms(client, "GET", "/health")}
            for name, (url, _page) in READS.items():
                client.get(url.format(**values))  # warm: compiled rig, templates, charts
                reads[name] = _median_ms(client, "GET", url.format(**values))
            times = []
            for k in range(REPEATS + 1):   # each at its own time and temperature
                at = START + SPACING * (size + k) + timedelta(seconds=7)
                sent = record | {"measured_at": at.isoformat(), "condition": dict(
                    record["condition"]) | {"oil_temperature": 40.0 + 0.01 * (k + 1)}}
                t1 = time.perf_counter()
                response = client.post("/diagnose", json={"record": sent})
                times.append((time.perf_counter() - t1) * 1e3)
                assert response.status_code == 200, response.text[-300:]
            reads[STORED] = statistics.median(times[1:])
    return {"diagnoses": size, "fill_s": round(fill_s, 1), "store_mib": round(mib, 1),
            "ms": {k: round(v, 1) for k, v in reads.items()}}


def run() -> dict[str, Any]:
    """Every size's store filled and read; the figures."""
    warnings.simplefilter("ignore", DeprecationWarning)
    runs = [_one_size(size) for size in SIZES]
    names = list(runs[0]["ms"])
    largest, smallest = runs[-1]["ms"], runs[0]["ms"]
    pages = [n for n, (_, page) in READS.items() if page]
    over = sorted(n for r in runs for n in pages if r["ms"][n] > TARGET_MS)
    trends = [n for n in READS if "trends" in n]
    return {
        "benchmark": "history_reads", "light": LIGHT, "sizes": list(SIZES),
        "store": "postgresql" if POSTGRES else "sqlite",
        "repeats": REPEATS, "runs": runs,
        "ratio_to_health_at_largest": {
            n: round(largest[n] / largest["GET /health"], 1) for n in names},
        "growth_smallest_to_largest": {n: round(largest[n] / smallest[n], 1) for n in names},
        "target_ms": TARGET_MS, "pages_within_target": not over,
        "pages_over_target": sorted(set(over)),
        "worst_page_ms_at_largest": max(largest[n] for n in pages),
        "trends_ms_at_largest": {n: largest[n] for n in trends},
        "trends_within_target_at_largest": all(largest[n] <= TARGET_MS for n in trends),
    }


def _table(result: dict[str, Any]) -> str:
    sizes = result["sizes"]
    head = "".join(f"{f'{s:,} [ms]':>16}" for s in sizes)
    lines = [f"history reads, rig 1, median of {result['repeats']} (in process, "
             f"{'PostgreSQL' if result['store'] == 'postgresql' else 'SQLite'})",
             f"{'read':<38}{head}{'× /health':>11}{'growth':>8}{'≤ 300 ms':>10}"]
    pages = {n for n, (_, page) in READS.items() if page}
    for name in result["runs"][0]["ms"]:
        cells = "".join(f"{r['ms'][name]:>16.1f}" for r in result["runs"])
        largest = result["runs"][-1]["ms"][name]
        verdict = ("yes" if largest <= TARGET_MS else "NO") if (
            name in pages or "trends" in name) else ""
        lines.append(f"{name:<38}{cells}{result['ratio_to_health_at_largest'][name]:>11.1f}"
                     f"{result['growth_smallest_to_largest'][name]:>8.1f}{verdict:>10}")
    lines.append("stores: " + ", ".join(f"{r['diagnoses']:,} diagnoses {r['store_mib']} MiB "
                                        f"(filled in {r['fill_s']} s)" for r in result["runs"]))
    return "\n".join(lines)


def main() -> None:
    """Run the benchmark, print the table and, last, the JSON figures."""
    result = run()
    print(_table(result))
    print(json.dumps(result))


if __name__ == "__main__":
    main()
