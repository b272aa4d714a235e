"""Byte identity of ``POST /diagnose`` answers and stored rows across a speed change (issue 9).

``python -m benchmarks.response_identity save FILE`` starts ``hydrodiag serve`` (one server
process, one diagnosis process; embedded SQLite in a temporary folder, as
:func:`benchmarks.load_bench.serve`), sends it, one at a time, ~48 varied ``POST /diagnose``
requests — records of :mod:`benchmarks.diagnose_cases` on every sensor subset (bare
numbers, ``{value, u}`` and ``{value, bound}`` readings), stored and not, ``compact``,
single records, ``records`` batches each and joint, with and without ``measured_at``,
``rig_version`` stated, ``Idempotency-Key`` (first and replayed), and refused ones (a twin
of a stored record, an unknown rig, a malformed body, a joint batch of two rigs, a record
no rig can have), then ``GET`` and ``PUT /diagnose`` (405),
``/openapi.json`` and ``/health`` — and pickles each answer's
status, content type, replay header and body, and a dump of every table the requests
write (``measurements``, ``diagnoses``, ``diagnosis_records``, ``diagnosis_estimates``,
``idempotent_requests``);
``python -m benchmarks.response_identity compare FILE`` does it again and compares
**bytes**: nothing may differ.

What legitimately varies is normalised first: the request id of an error body, and every
time stamp within two days of the run (the time of a request: a record without
``measured_at``, its note, ``created_at``), written ``<now>``.  Ids are kept: the requests
go one at a time, so a store gives the same ids each run.
"""

from __future__ import annotations

import json
import os
import pickle
import re
import sqlite3
import sys
import tempfile
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import httpx
import numpy as np

from benchmarks.diagnose_cases import FULL, SUBSETS, random_records
from benchmarks.load_bench import serve
from diagnostics.measurement import MeasurementRecord
from sim.rigs import reference_rig

#: the tables a diagnosis writes, and the order their rows are dumped in
TABLES = ("measurements", "diagnoses", "diagnosis_records", "diagnosis_estimates",
          "idempotent_requests")

_STAMP = re.compile(rb"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(?:\.\d+)?(?:Z|[+-]\d\d:\d\d)?")
_STAMP_TEXT = re.compile(r"\d{4}-\d\d-\d\d[T ]\d\d:\d\d:\d\d(?:\.\d+)?(?:Z|[+-]\d\d:\d\d)?")
_REQUEST_ID = re.compile(rb'"request_id":"[^"]*"')
_WINDOW = timedelta(days=2)


def _recent(text: str, now: datetime) -> bool:
    try:
        t = datetime.fromisoformat(text.replace("Z", "+00:00").replace(" ", "T"))
    except ValueError:
        return False
    if t.tzinfo is None:
        t = t.replace(tzinfo=UTC)
    return abs(t - now) < _WINDOW


def _normal_bytes(body: bytes, now: datetime) -> bytes:
    body = _REQUEST_ID.sub(b'"request_id":"<id>"', body)
    return _STAMP.sub(lambda m: b"<now>" if _recent(m.group().decode(), now) else m.group(),
                      body)


def _normal_value(value: Any, now: datetime) -> Any:
    if isinstance(value, str):
        return _STAMP_TEXT.sub(lambda m: "<now>" if _recent(m.group(), now) else m.group(),
                               value)
    if isinstance(value, bytes):
        return _normal_bytes(value, now)
    return value


def _reading(value: float, style: int) -> Any:
    if style == 1:
        return {"value": value, "u": abs(value) * 0.004 + 1e-9}
    if style == 2:
        return {"value": value, "bound": abs(value) * 0.01 + 1e-9}
    return value


def _body_record(rec: MeasurementRecord, rng: np.random.Generator, *,
                 measured_at: str | None, version: int | None = None) -> dict[str, Any]:
    """The JSON record of ``rec``: every reading bare, or with ``u`` or ``bound``."""
    out: dict[str, Any] = {"rig_id": 1}
    if version is not None:
        out["rig_version"] = version
    if measured_at is not None:
        out["measured_at"] = measured_at
    cond = rec.condition
    condition: dict[str, Any] = {"oil_temperature": float(cond.oil_temperature.value)}
    if cond.load_force is not None:
        condition["load_force"] = float(cond.load_force.value)
    out["condition"] = condition
    style = int(rng.integers(3))
    for name in (*FULL, "velocity_ratio"):
        q = getattr(rec, name)
        if q is not None:
            out[name] = _reading(float(q.value), style if rng.uniform() < 0.7 else 0)
    return out


def requests() -> list[tuple[dict[str, Any] | str, dict[str, str]]]:
    """The bodies (a dict as JSON, a str as sent) and extra headers, in order."""
    rig = reference_rig()
    rng = np.random.default_rng(11)
    recs = random_records(rng, rig, 30, SUBSETS) + random_records(rng, rig, 6, [FULL])
    stamp = iter(f"2026-05-{1 + i // 24:02d}T{i % 24:02d}:15:00Z" for i in range(10_000))

    def rec(i: int, timed: bool = True, **kw: Any) -> dict[str, Any]:
        return _body_record(recs[i % len(recs)], rng,
                            measured_at=next(stamp) if timed else None, **kw)

    out: list[tuple[dict[str, Any] | str, dict[str, str]]] = []
    for i in range(18):  # single stored records, every subset, timed or not
        out.append(({"record": rec(i, timed=i % 5 != 3)}, {}))
    for i in range(18, 22):
        out.append(({"record": rec(i), "compact": True}, {}))
    for i in range(22, 26):
        out.append(({"record": rec(i), "store": False, "compact": i % 2 == 0}, {}))
    out.append(({"record": rec(26, version=1)}, {}))
    out.append(({"records": [rec(27), rec(28, timed=False), rec(29)]}, {}))
    out.append(({"records": [rec(30), rec(31)], "compact": True}, {}))
    out.append(({"records": [rec(32), rec(33)], "joint": True}, {}))
    out.append(({"records": [rec(34, timed=False), rec(35, timed=False)], "joint": True,
                 "store": False}, {}))
    twin = rec(1)
    out.append(({"record": twin}, {}))
    out.append(({"record": twin}, {}))  # a twin of a stored record: 409
    keyed = {"record": rec(3)}
    out.append((keyed, {"Idempotency-Key": "identity-1"}))
    out.append((keyed, {"Idempotency-Key": "identity-1"}))  # replayed
    out.append(({"records": [rec(5), rec(6)]}, {"Idempotency-Key": "identity-2"}))
    out.append(({"record": rec(7) | {"rig_id": 99}}, {}))  # unknown rig: 404
    out.append(({"record": rec(8) | {"rig_version": 99}}, {}))  # unknown version
    out.append(({"records": [rec(9), rec(10) | {"rig_id": 2}], "joint": True}, {}))
    out.append(({"record": rec(11) | {"p1": "NaN"}}, {}))  # text reading: 422
    out.append(({"record": rec(12) | {"flow_B": {"value": 1e-4, "u": 1e-6, "bound": 1e-6}}},
                {}))
    out.append(({"record": rec(13), "records": [rec(14)]}, {}))
    out.append(({"records": [rec(15)], "joint": True}, {}))
    out.append(({"record": rec(16) | {"speed_work": -0.5}}, {}))  # impossible reading
    out.append(('{"record": {"rig_id": 1, "condition": {', {}))  # malformed JSON
    out.append(({"record": {"rig_id": 1, "condition": {"oil_temperature": 40.0}}}, {}))
    for i in range(17, 21):  # a second pass of stored records: their maps cached now
        out.append(({"record": rec(i)}, {}))
    return out


def _dump(data_dir: Path, now: datetime) -> dict[str, list[tuple[Any, ...]]]:
    with sqlite3.connect(data_dir / "hydrodiag.db") as connection:
        out = {}
        for table in TABLES:
            rows = connection.execute(f"SELECT * FROM {table} ORDER BY rowid").fetchall()
            out[table] = [tuple(_normal_value(v, now) for v in row) for row in rows]
    return out


def outputs() -> dict[str, Any]:
    """Every answer (status, content type, replay header, body) and the tables' rows."""
    os.environ["HYDRODIAG_WORKERS"] = "1"
    os.environ["HYDRODIAG_DIAGNOSIS_WAIT_MS"] = "600000"
    now = datetime.now(UTC)
    answers: list[tuple[Any, ...]] = []
    with tempfile.TemporaryDirectory(prefix="hydrodiag-identity-") as folder, \
            serve(Path(folder)) as service, \
            httpx.Client(base_url=service.base_url, timeout=120,
                         headers={"X-API-Key": service.key}) as http:
        for body, headers in requests():
            content = (body if isinstance(body, str) else json.dumps(body)).encode()
            r = http.post("/diagnose", content=content,
                          headers=headers | {"Content-Type": "application/json"})
            answers.append((r.status_code, r.headers.get("content-type"),
                            r.headers.get("idempotent-replayed"),
                            _normal_bytes(r.content, now)))
        for method, path in (("GET", "/diagnose"), ("PUT", "/diagnose"),  # 405, its Allow
                             ("GET", "/openapi.json"), ("GET", "/health")):
            r = http.request(method, path)
            answers.append((r.status_code, r.headers.get("content-type"), r.headers.get("allow"),
                            _normal_bytes(r.content, now)))
        tables = _dump(Path(folder), now)
    return {"answers": answers, "tables": tables}


def compare(ref: dict[str, Any], new: dict[str, Any],
            say: Callable[[str], None] = print) -> int:
    """The number of differences of ``new`` from ``ref`` (each printed, at most 20)."""
    bad = 0

    def report(text: str) -> None:
        nonlocal bad
        bad += 1
        if bad <= 20:
            say(text)

    if len(ref["answers"]) != len(new["answers"]):
        report(f"answers: {len(ref['answers'])} then {len(new['answers'])}")
    for i, (a, b) in enumerate(zip(ref["answers"], new["answers"], strict=False)):
        if a != b:
            at = next((k for k, (x, y) in enumerate(zip(a[3], b[3], strict=False)) if x != y),
                      min(len(a[3]), len(b[3])))
            report(f"answer {i}: status {a[0]}/{b[0]}, type {a[1]}/{b[1]}, replayed "
                   f"{a[2]}/{b[2]}, {len(a[3])}/{len(b[3])} bytes, first difference at "
                   f"{at}: {a[3][max(0, at - 40):at + 40]!r} / {b[3][max(0, at - 40):at + 40]!r}")
    for table in TABLES:
        x, y = ref["tables"][table], new["tables"][table]
        if len(x) != len(y):
            report(f"{table}: {len(x)} rows then {len(y)}")
        for j, (u, v) in enumerate(zip(x, y, strict=False)):
            if u != v:
                cols = [k for k, (p, q) in enumerate(zip(u, v, strict=False)) if p != q]
                report(f"{table} row {j}: columns {cols} differ: "
                       f"{[str(u[k])[:80] for k in cols]} / {[str(v[k])[:80] for k in cols]}")
    rows = sum(len(v) for v in ref["tables"].values())
    statuses = sorted({a[0] for a in ref["answers"]})
    print(f"compared {len(ref['answers'])} answers (statuses {statuses}, "
          f"{sum(len(a[3]) for a in ref['answers'])} bytes) and {rows} stored rows: "
          f"{bad} differences")
    return bad


def main() -> None:
    if len(sys.argv) != 3 or sys.argv[1] not in ("save", "compare"):
        sys.exit("usage: python -m benchmarks.response_identity save|compare FILE")
    path = Path(sys.argv[2])
    res = outputs()
    if sys.argv[1] == "save":
        path.write_bytes(pickle.dumps(res))
        rows = sum(len(v) for v in res["tables"].values())
        print(f"saved {len(res['answers'])} answers and {rows} stored rows to {path}")
        return
    sys.exit(1 if compare(pickle.loads(path.read_bytes()), res) else 0)


if __name__ == "__main__":
    main()
