"""Where a stored ``POST /diagnose`` spends its CPU, in the server and the diagnosis process.

Starts ``hydrodiag serve`` with one server process and one diagnosis process
(``HYDRODIAG_WORKERS=1``), warms it, then samples both processes with py-spy (an external
sampling profiler, ``pip install py-spy``; not a dependency of the project; ``--gil``:
only the thread holding the interpreter lock, i.e. Python CPU, no waits) while
``CONCURRENCY`` clients send ``N_REQUESTS`` stored diagnoses back to back.  Prints, per
process, the share of samples whose stack passes through each part (a sample counts in
every part its stack holds, so the shares of nested parts overlap), and the top functions
by own time.  The last line is one JSON object with the shares.

First the same traffic without the profiler, its CPU per request read from ``/proc`` for
the server process, the diagnosis process and this load generator (admission by expected
wait switched off: every request is served, none is a cheap 503).

Run: ``python -m benchmarks.load_profile`` (``HYDRODIAG_LIGHT=1``: fewer requests).
"""

from __future__ import annotations

import asyncio
import collections
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.load_bench import (
    Bodies,
    _base_records,
    _is_diagnosis_process,
    _per_request_ms,
    cpu_meter,
    serve,
)
from benchmarks.load_clients import closed_loop, request_bytes
from benchmarks.soak_probe import process_tree

LIGHT = os.environ.get("HYDRODIAG_LIGHT") == "1"
CONCURRENCY = 4
N_REQUESTS = 300 if LIGHT else 1500
RATE_HZ = 500

#: Parts of a request, by a substring of a frame (``function (file)``) in the stack.
PARTS: dict[str, tuple[str, ...]] = {
    "http (uvicorn/httptools)": ("uvicorn/protocols",),
    "middleware (log, metrics, limits)": ("app/logs.py", "app/metrics.py", "app/limits.py"),
    "request validation (pydantic)": ("validate_python", "model_validate", "solve_dependencies",
                                      "request_body_to_args", "_validate_inner"),
    "route /diagnose": ("routes/diagnose.py",),
    "key check": ("app/security.py", "deps.py"),
    "pipe + pickle (server)": ("_on_answer", "send_whole", "_dispatch"),
    "group commit (sqlalchemy)": ("group_commit.py",),
    "diagnosis task": ("run_task",),
    "  json.loads + validation (worker)": ("json.loads", "model_validate"),
    "  plan (rig, records)": ("plan_groups", "plan_forms"),
    "  diagnose()": ("compute_group",),
    "  answer + rows serialised": ("answer_of",),
    "pickle (worker)": ("pickle", "dumps", "loads"),
}


def _collapse(path: Path) -> list[tuple[list[str], int]]:
    stacks = []
    for line in path.read_text(encoding="utf-8").splitlines():
        stack, _, count = line.rpartition(" ")
        stacks.append((stack.split(";"), int(count)))
    return stacks


def _summary(stacks: list[tuple[list[str], int]]) -> dict[str, Any]:
    total = sum(c for _, c in stacks) or 1
    shares = {}
    for part, needles in PARTS.items():
        hit = sum(c for frames, c in stacks
                  if any(n in f for f in frames for n in needles))
        shares[part.strip()] = hit / total
    own: collections.Counter[str] = collections.Counter()
    for frames, c in stacks:
        own[frames[-1]] += c
    inclusive: collections.Counter[str] = collections.Counter()
    for frames, c in stacks:
        for f in set(frames):
            if "app/" in f or "diagnostics/diagnose.py" in f:
                inclusive[f] += c
    return {"samples": total, "shares": shares,
            "top_own": [(f, c / total) for f, c in own.most_common(15)],
            "top_app": [(f, c / total) for f, c in inclusive.most_common(25)]}


def main() -> None:
    """Profile, print the tables, then the JSON object as the last line."""
    import sys
    spy = shutil.which("py-spy") or shutil.which("py-spy", path=str(Path(sys.executable).parent))
    if spy is None:
        raise SystemExit("py-spy is needed: pip install py-spy")
    os.environ["HYDRODIAG_WORKERS"] = "1"
    os.environ["HYDRODIAG_DIAGNOSIS_WAIT_MS"] = "600000"  # every request in: CPU, not 503s
    out: dict[str, Any] = {"load_average_before": os.getloadavg()}
    with tempfile.TemporaryDirectory(prefix="hydrodiag-profile-") as folder, \
            serve(Path(folder)) as service:
        bodies = Bodies(_base_records(service))
        headers = {"X-API-Key": service.key}

        def diagnoses(n: int) -> list[bytes]:
            return [request_bytes(service.base_url, "POST", "/diagnose", bodies(), headers)
                    for _ in range(n)]

        asyncio.run(closed_loop(service.base_url, diagnoses(30), CONCURRENCY))
        cpu: dict[str, Any] = {}
        requests = diagnoses(N_REQUESTS)
        with cpu_meter(service.process.pid, cpu):
            cpu |= asyncio.run(closed_loop(service.base_url, requests, CONCURRENCY))
        out["cpu_ms_per_request"] = _per_request_ms(cpu)
        out["cpu_phase"] = cpu
        pids = process_tree(service.process.pid)
        worker = next(p for p in pids if _is_diagnosis_process(p))
        server = service.process.pid  # one worker: uvicorn serves in the process of serve
        files = {"server": Path(folder) / "server.txt", "diagnosis": Path(folder) / "diag.txt"}
        spies = [subprocess.Popen([spy, "record", "--gil", "--rate", str(RATE_HZ),
                                   "--format", "raw", "-o", str(files[name]), "--pid",
                                   str(pid)], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL)
                 for name, pid in (("server", server), ("diagnosis", worker))]
        time.sleep(2.0)
        requests = diagnoses(N_REQUESTS)
        figures = asyncio.run(closed_loop(service.base_url, requests, CONCURRENCY))
        for s in spies:
            s.send_signal(2)
        for s in spies:
            s.wait(timeout=60)
        for name, path in files.items():
            out[name] = _summary(_collapse(path))
    out["closed_loop"] = figures
    out["load_average_after"] = os.getloadavg()
    for name in files:
        print(f"== {name} process: {out[name]['samples']} samples")
        for part, share in out[name]["shares"].items():
            print(f"  {part:<40} {100 * share:6.1f} %")
        print("  top own time:")
        for frame, share in out[name]["top_own"]:
            print(f"    {100 * share:5.1f} %  {frame[:110]}")
        print("  top app functions, inclusive:")
        for frame, share in out[name]["top_app"]:
            print(f"    {100 * share:5.1f} %  {frame[:110]}")
    print("CPU per stored /diagnose [ms] (closed loop, no profiler): " + ", ".join(
        f"{k.split('_cpu')[0]} {v:.2f}" for k, v in out["cpu_ms_per_request"].items())
        + f"; errors {out['cpu_phase']['errors']:.0f}")
    print(f"closed loop: p50 {figures['p50_ms']:.1f} ms, {figures['throughput_rps']:.0f}/s")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
