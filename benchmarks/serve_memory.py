"""Memory of ``hydrodiag serve``'s processes: what a container's limit must hold.

Starts ``hydrodiag serve`` with one and with two server workers (fresh store, the reference
rig), reads the proportional set size (PSS: each shared page split among the processes
that share it, so the figures add up) of every process once the service is ready, then
again after transient sweeps until every worker has started its sweep pool.  Each process
is put in its role: the supervisor, a server worker, spawn's resource tracker, a
diagnosis process (a worker's process before any sweep), a sweep process (one the sweeps
started).  The median of each role is printed beside the size
:func:`app.cgroup_limits.memory_warning` takes for it, and the totals ready and after the
sweeps.  The last line is one JSON object with the figures.

Run: ``make serve-memory`` (no light form: two starts and a few sweeps, ~1 min).
"""

from __future__ import annotations

import json
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

from app.cgroup_limits import DIAGNOSIS_MIB, SUPERVISOR_MIB, SWEEP_MIB, WORKER_MIB
from benchmarks.load_bench import serve
from benchmarks.soak_probe import parent_of, process_tree, role

#: sweeps sent at most to get every worker's pool started [-]
MAX_SWEEPS = 12
#: the size memory_warning takes for each role [MiB]
STATED = {"serve": SUPERVISOR_MIB, "worker": WORKER_MIB, "diagnosis": DIAGNOSIS_MIB,
          "sweep": SWEEP_MIB}
SWEEP = {"rig_id": 1, "faults": ["healthy"], "method": "transient",
         "conditions": [{"name": "load", "low": 2100, "high": 4200, "levels": 4}]}


def pss_mib(pid: int) -> float:
    """Proportional set size of process ``pid`` [MiB] (0 for one gone)."""
    try:
        text = Path(f"/proc/{pid}/smaps_rollup").read_text(encoding="utf-8")
    except OSError:
        return 0.0
    for line in text.splitlines():
        if line.startswith("Pss:"):
            return int(line.split()[1]) / 1024
    return 0.0


def _roles(root: int, workers: int, diagnosis: set[int]) -> dict[int, str]:
    """Each live process of the service and its role (module docstring): the soak's
    :func:`~benchmarks.soak_probe.role`, with one worker the supervisor being the worker
    (its spawned processes its own), and a worker's own processes told apart by
    ``diagnosis``, those known to be diagnosis processes (the others: sweep processes)."""
    out = {}
    for pid in process_tree(root):
        kind = role(pid, root)
        if workers == 1:
            kind = {"serve": "worker", "worker": "child"}.get(kind, kind)
        if kind == "child":
            kind = "diagnosis" if pid in diagnosis else "sweep"
        out[pid] = kind
    return out


def _sweep_until_every_pool(base_url: str, key: str, root: int, workers: int,
                            diagnosis: set[int]) -> int:
    """Send sweeps, each on a new connection (the kernel spreads them over the workers),
    until every worker has a sweep process; the number sent."""
    for sent in range(1, MAX_SWEEPS + 1):
        job = httpx.post(f"{base_url}/scenarios", headers={"X-API-Key": key}, json=SWEEP,
                         timeout=120).json()["job_id"]
        while httpx.get(f"{base_url}/jobs/{job}", headers={"X-API-Key": key},
                        timeout=60).json()["status"] in ("queued", "running"):
            time.sleep(0.2)
        sweeping = {_parent(p) for p, kind in _roles(root, workers, diagnosis).items()
                    if kind == "sweep"}
        if len(sweeping) >= workers:
            return sent
    return MAX_SWEEPS


def _parent(pid: int) -> int:
    try:
        return parent_of(pid)
    except (OSError, ValueError):
        return 0


def _snapshot(root: int, workers: int, diagnosis: set[int]) -> dict[str, Any]:
    sizes: dict[str, list[float]] = {}
    for pid, kind in _roles(root, workers, diagnosis).items():
        sizes.setdefault(kind, []).append(pss_mib(pid))
    return {"total_mib": round(sum(sum(v) for v in sizes.values()), 1),
            "roles": {k: {"n": len(v), "median_mib": round(statistics.median(v), 1)}
                      for k, v in sorted(sizes.items())}}


def measure(workers: int) -> dict[str, Any]:
    """The figures of one start with ``workers`` server workers."""
    with tempfile.TemporaryDirectory() as folder, \
            serve(Path(folder), env={"HYDRODIAG_WORKERS": str(workers)}) as service:
        root = service.process.pid
        time.sleep(1.0)
        # before any sweep every spawned process below a worker is a diagnosis process
        diagnosis = {p for p, kind in _roles(root, workers, set()).items() if kind == "sweep"}
        ready = _snapshot(root, workers, diagnosis)
        sweeps = _sweep_until_every_pool(service.base_url, service.key, root, workers,
                                         diagnosis)
        time.sleep(1.0)
        after = _snapshot(root, workers, diagnosis)
    return {"workers": workers, "sweeps_sent": sweeps, "ready": ready,
            "after_sweeps": after}


def _table(runs: list[dict[str, Any]]) -> str:
    lines = [f"{'workers':>7}  {'role':<10} {'n':>3} {'ready [MiB]':>12} "
             f"{'after sweeps':>13} {'stated':>7}"]
    for run in runs:
        ready, after = run["ready"]["roles"], run["after_sweeps"]["roles"]
        for kind in sorted(set(ready) | set(after)):
            r, a = ready.get(kind), after.get(kind)
            n = (a or r or {}).get("n", 0)
            lines.append(f"{run['workers']:>7}  {kind:<10} {n:>3} "
                         f"{'' if r is None else r['median_mib']:>12} "
                         f"{'' if a is None else a['median_mib']:>13} "
                         f"{STATED.get(kind, ''):>7}")
        lines.append(f"{run['workers']:>7}  {'total':<10} {'':>3} "
                     f"{run['ready']['total_mib']:>12} {run['after_sweeps']['total_mib']:>13}")
    return "\n".join(lines)


def main() -> None:
    runs = [measure(workers) for workers in (1, 2)]
    print("memory of hydrodiag serve's processes, proportional set size, median per role "
          "(stated: the size app.cgroup_limits.memory_warning takes)")
    print(_table(runs))
    print(json.dumps({"runs": runs, "stated_mib": STATED}))


if __name__ == "__main__":
    main()
