"""Server-side render time of every console page for a rig with 1,000 stored diagnoses.

Run by ``make console-bench``.  A fresh SQLite store gets the reference rig and
``N_DIAGNOSES`` diagnoses of it: ``N_REAL`` records of a valve wearing from 34 to 60 µm
are simulated (steady path) and diagnosed for real, then each stored result is repeated
at further times (one a day) with the same estimates, so the history, the pagination and
the trends carry the full number of rows.  Each page is then requested in process
(``fastapi.testclient``: the whole ASGI stack, login cookie included, no network)
``REPEATS`` times; the median is its render time.  The baseline, measured in the same
run, is ``GET /health`` (the cheapest answer of the service): each page's time is also
given as a ratio to it.  Target: ≤ 300 ms per page.

``HYDRODIAG_LIGHT=1``: 200 diagnoses, 3 repeats.  Last line: one JSON object.
"""

from __future__ import annotations

import json
import os
import statistics
import tempfile
import time
import warnings
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

LIGHT = os.environ.get("HYDRODIAG_LIGHT") == "1"
N_DIAGNOSES = 200 if LIGHT else 1000
N_REAL = 5
REPEATS = 3 if LIGHT else 10
TARGET_MS = 300.0

PAGES = {
    "rigs": "/console/rigs",
    "rig": "/console/rigs/1",
    "diagnose form": "/console/diagnose",
    "diagnosis": "/console/diagnoses/{last}",
    "history p1": "/console/history?rig=1",
    "history last page": "/console/history?rig=1&page={last_page}",
    "trends": "/console/trends?rig=1",
    "simulate form": "/console/simulate",
    "simulate run": "/console/simulate?run=true&fault=worn_spool",
    "pumps": "/console/pumps",
    # not a console page: the API's trend answer, the service work under the trends page
    "(API /rigs/1/trends)": "/rigs/1/trends",
}


def _fill(app: Any, client: Any, key: str) -> int:
    """Store N_DIAGNOSES diagnoses of rig 1; return the last one's id."""
    from app.db.models import Diagnosis
    from app.services.history import ComponentEstimate, add_diagnosis
    from benchmarks.wearing_valve import diagnose_wearing_valve

    start = datetime(2026, 1, 1, 8, tzinfo=UTC)
    real = diagnose_wearing_valve(client, [start + timedelta(days=i) for i in range(N_REAL)],
                                  headers={"X-API-Key": key})
    with app.state.sessions() as session:
        rows = [session.get(Diagnosis, i) for i in real]
        for n in range(N_REAL, N_DIAGNOSES):
            row = rows[n % N_REAL]
            assert row is not None
            at = start + timedelta(days=n)
            add_diagnosis(
                session, rig_id=1, measured_at=at,
                record=dict(row.measurement.record) | {"measured_at": at.isoformat()},
                result=row.result, component=row.component, probability=row.probability,
                estimates=[ComponentEstimate(e.component, e.probability, e.clearance_m,
                                             e.slip_coefficient) for e in row.estimates],
                rig_version_id=row.rig_version_id)
        session.commit()
        last = session.query(Diagnosis.id).order_by(Diagnosis.id.desc()).first()
    assert last is not None
    return int(last[0])


def _median_ms(client: Any, url: str) -> float:
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        response = client.get(url)
        times.append((time.perf_counter() - t0) * 1e3)
        assert response.status_code == 200, (url, response.status_code, response.text[-300:])
    return statistics.median(times)


def run() -> dict[str, Any]:
    """Fill a fresh store, time every page; return the figures."""
    warnings.simplefilter("ignore", DeprecationWarning)
    from fastapi.testclient import TestClient

    from app.console.views import HISTORY_PAGE
    from app.main import create_app
    from app.services.keys import create_api_key
    from app.settings import Settings

    with tempfile.TemporaryDirectory(prefix="hydrodiag-console-bench-") as folder:
        app = create_app(Settings(data_dir=Path(folder)))
        with TestClient(app) as client:
            with app.state.sessions() as session:
                key = create_api_key(session, "console-bench")[1]
            client.headers["X-API-Key"] = key  # every API operation needs the key
            t0 = time.perf_counter()
            last = _fill(app, client, key)
            fill_s = time.perf_counter() - t0
            assert client.post("/console/login", data={"api_key": key, "next": ""},
                               follow_redirects=False).status_code == 303
            last_page = -(-N_DIAGNOSES // HISTORY_PAGE)
            for url in PAGES.values():  # warm: compiled rig, templates, matplotlib
                client.get(url.format(last=last, last_page=last_page))
            baseline = _median_ms(client, "/health")
            pages = {name: _median_ms(client, url.format(last=last, last_page=last_page))
                     for name, url in PAGES.items()}
    console = {k: v for k, v in pages.items() if not k.startswith("(")}
    worst = max(console, key=lambda k: console[k])
    return {
        "benchmark": "console_render", "light": LIGHT, "diagnoses": N_DIAGNOSES,
        "repeats": REPEATS, "fill_s": round(fill_s, 2), "baseline_health_ms": round(baseline, 2),
        "pages_ms": {k: round(v, 1) for k, v in pages.items()},
        "pages_ratio_to_health": {k: round(v / baseline, 1) for k, v in pages.items()},
        "worst_page": worst, "worst_ms": round(pages[worst], 1), "target_ms": TARGET_MS,
        "all_within_target": all(v <= TARGET_MS for v in console.values()),
        "pages_over_target": sorted(k for k, v in console.items() if v > TARGET_MS),
    }


def _table(result: dict[str, Any]) -> str:
    lines = [f"console render time, {result['diagnoses']} diagnoses of rig 1, median of "
             f"{result['repeats']} (baseline GET /health {result['baseline_health_ms']} ms)",
             f"{'page':<22}{'ms':>10}{'× /health':>12}{'≤ 300 ms':>10}"]
    for name, ms in result["pages_ms"].items():
        ratio = result["pages_ratio_to_health"][name]
        verdict = "" if name.startswith("(") else "yes" if ms <= TARGET_MS else "NO"
        lines.append(f"{name:<22}{ms:>10.1f}{ratio:>12.1f}{verdict:>10}")
    return "\n".join(lines)


def main() -> None:
    """Run the benchmark, print the table and, last, the JSON figures."""
    result = run()
    print(_table(result))
    print(json.dumps(result))


if __name__ == "__main__":
    main()
