"""How long a discrepancy run in a server thread keeps the other threads waiting.

Run by ``make job-stall``.  A discrepancy job runs in a thread of the server process
(:mod:`app.services.jobs`), so whatever it does while holding the interpreter lock, every
other request of that process waits for, ``/health`` included.  The compiled models
release the lock (``nogil``, :mod:`sim.bondgraph.codegen`); the Python around them does
not.  This study runs :func:`diagnostics.discrepancy.workflow.discover` on three noisy
cycles of the reference rig (2.1/4.2/6.3 kN at 40/50/60 °C) in a thread while the main
thread sleeps 1 ms again and again and records how late it wakes; the baseline is the same
loop with nothing beside it, measured in the same run.  Target: the late wakes' 99th
percentile ≤ 20 ms (the ``/health`` p99 of issue 9).

Then the pump-leak estimate of ``POST /rigs/{id}/pump-leak`` the same way, in a thread and
on a process, where the service runs it (:mod:`benchmarks.job_stall_leak`, JSON
``pump_leak``).

``HYDRODIAG_LIGHT=1``: one run of the workflow instead of three, every 4th ZeMA cycle.
Last line: one JSON object.
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Callable

import numpy as np

from benchmarks.job_stall_leak import leak_stalls

LIGHT = os.environ.get("HYDRODIAG_LIGHT") == "1"
RUNS = 1 if LIGHT else 3
#: the loop's sleep [s]
TICK = 0.001
TARGET_P99_MS = 20.0


def _lateness(busy: Callable[[], object] | None, span: float) -> np.ndarray:
    """How late [ms] each 1 ms sleep of this thread woke, while ``busy`` runs in another
    thread (until it returns) or, without it, for ``span`` seconds."""
    done = threading.Event()
    worker = None
    if busy is not None:
        def run() -> None:
            try:
                busy()
            finally:
                done.set()
        worker = threading.Thread(target=run)
        worker.start()
    late: list[float] = []
    end = time.perf_counter() + span
    while (not done.is_set()) if busy is not None else (time.perf_counter() < end):
        t0 = time.perf_counter()
        time.sleep(TICK)
        late.append((time.perf_counter() - t0 - TICK) * 1e3)
    if worker is not None:
        worker.join()
    return np.asarray(late)


def main() -> None:
    from diagnostics.discrepancy.synthetic import synthesize
    from diagnostics.discrepancy.workflow import discover
    from sim.rigs import load_rig, reference_rig_document
    from sim.rigs.assembly import Condition

    doc = reference_rig_document()
    rig = load_rig(doc)
    rng = np.random.default_rng(1)
    records = [synthesize(rig, Condition(load=load, oil_temperature=temp), rng=rng,
                          name=f"L{load:.0f}")
               for load, temp in ((2100.0, 40.0), (4200.0, 50.0), (6300.0, 60.0))]
    discover(doc, records[:2], bootstrap=0)  # compiled models loaded, caches warm
    started = time.perf_counter()
    beside = [_lateness(lambda: discover(doc, records, bootstrap=10), 0.0)
              for _ in range(RUNS)]
    work_s = (time.perf_counter() - started) / RUNS
    idle = _lateness(None, min(work_s, 3.0))
    late = np.concatenate(beside)
    rows = [("idle (baseline)", idle), ("beside a discrepancy run", late)]
    print(f"discrepancy runs: {RUNS}, {work_s:.2f} s each (3 cycles, bootstrap 10)")
    print(f"{'':28}{'wakes':>8}{'median ms':>11}{'p99 ms':>9}{'max ms':>9}{'> 20 ms':>9}")
    for name, a in rows:
        print(f"{name:28}{a.size:>8}{np.median(a):>11.2f}{np.percentile(a, 99):>9.1f}"
              f"{a.max():>9.1f}{int((a > 20.0).sum()):>9}")
    p99 = float(np.percentile(late, 99))
    base_p99 = float(np.percentile(idle, 99))
    print(f"target: p99 ≤ {TARGET_P99_MS:g} ms beside the run: "
          f"{'met' if p99 <= TARGET_P99_MS else 'MISSED'}")
    leak = leak_stalls(_lateness, LIGHT, RUNS)
    if leak is not None:
        leak["met"] = float(leak["process_p99_ms"]) <= TARGET_P99_MS  # type: ignore[arg-type]
        print(f"target: p99 ≤ {TARGET_P99_MS:g} ms beside the pump-leak estimate on its "
              f"process: {'met' if leak['met'] else 'MISSED'}")
    print(json.dumps({
        "runs": RUNS, "run_s": round(work_s, 3), "wakes": int(late.size),
        "late_p99_ms": round(p99, 2), "late_max_ms": round(float(late.max()), 2),
        "late_median_ms": round(float(np.median(late)), 3),
        "idle_p99_ms": round(base_p99, 3),
        "p99_ratio_to_idle": round(p99 / base_p99, 1) if base_p99 > 0 else None,
        "target_p99_ms": TARGET_P99_MS, "met": p99 <= TARGET_P99_MS, "pump_leak": leak,
        "load_average_1min": os.getloadavg()[0]}))


if __name__ == "__main__":
    main()
