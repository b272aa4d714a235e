"""The pump-leak estimate beside ``/health``: in the request's thread, and on a process.

Called by :func:`benchmarks.job_stall.main` (``make job-stall``).  The estimate of
``POST /rigs/{id}/pump-leak`` (:func:`diagnostics.real.monitor.monitor_pump_leak`) on the
ZeMA cycles (light: every 4th) runs, again and again, in a thread of this process — where
it ran at first — and on a spawned process of a ``ProcessPoolExecutor``, warmed first —
where the service runs it, on the sweeps' executor, the cycles sent packed
(:func:`~diagnostics.real.monitor.pack_cycles`) — while this thread sleeps 1 ms and
records how late it wakes (``benchmarks.job_stall._lateness``).  Its thousands of small
numpy calls each let go of the interpreter lock and take it back at once, and a waiting
thread asks for the lock only when nobody took it for the 5 ms switch interval: in a
thread the waits run to a hundred ms and more.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor

import numpy as np

__all__ = ["leak_stalls"]


def leak_stalls(lateness: Callable[[Callable[[], object] | None, float], np.ndarray],
                light: bool, runs: int) -> dict[str, object] | None:
    """Print the waits beside the estimate in a thread and on a process; their figures
    (None, said, where the shared ZeMA data are absent)."""
    from diagnostics.real.monitor import monitor_packed, monitor_pump_leak, pack_cycles
    from diagnostics.real.zema import load_1hz, read_records, zema_root
    from sim.errors import InputError
    from sim.fluid import Fluid

    try:
        root = zema_root()
    except InputError as exc:
        print(f"pump-leak part skipped: {exc.message}")
        return None
    if not (root / "profile.txt").is_file():
        print(f"pump-leak part skipped: no ZeMA data at {root}")
        return None
    n_all = sum(1 for _ in (root / "profile.txt").open())
    data, _ = load_1hz(root, list(range(1, n_all + 1, 4 if light else 1)))
    records = read_records(data)
    fluid = Fluid()
    monitor_pump_leak(records[::10], fluid)
    thread = np.concatenate([lateness(lambda: monitor_pump_leak(records, fluid), 0.0)
                             for _ in range(runs)])
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        pool.submit(monitor_pump_leak, records[::10], fluid).result()  # imported, warm
        process = np.concatenate([  # packed as the service sends them
            lateness(lambda: pool.submit(monitor_packed, pack_cycles(records), fluid).result(),
                     0.0) for _ in range(runs)])
    print(f"pump-leak estimate of {len(records)} ZeMA cycles, {runs} run(s) each way:")
    for name, a in (("in a thread (before)", thread), ("on a process (the service)", process)):
        print(f"{name:28}{a.size:>8}{np.median(a):>11.2f}{np.percentile(a, 99):>9.1f}"
              f"{a.max():>9.1f}{int((a > 20.0).sum()):>9}")
    return {"cycles": len(records), "thread_p99_ms": round(float(np.percentile(thread, 99)), 2),
            "thread_max_ms": round(float(thread.max()), 2),
            "process_p99_ms": round(float(np.percentile(process, 99)), 2),
            "process_max_ms": round(float(process.max()), 2)}
