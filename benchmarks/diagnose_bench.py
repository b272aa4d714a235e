"""Speed of the diagnosis, fast (compiled) against direct path (issue 9): ``make diagnose-bench``.

Records: random faults of the library at random severities on the paper-002 rig, each at
its own oil temperature (20-60 °C) and load (5-60 % of the stall load), all seven
readings with instrument noise (:mod:`benchmarks.diagnose_cases`).

* **new conditions** — in-process :func:`diagnostics.diagnose.diagnose` of records that
  each bring a new condition (signature maps built, healthy sensitivities solved), median
  per record, fast and direct path on different records of the same kind;
* **warm** — one record diagnosed again and again (maps cached), median;
* **batch** — :func:`diagnostics.batch.diagnose_many` over 10,000 records (light: 500):
  records/s in this process, on a 2-process pool and on a 2-worker Dask ``LocalCluster``
  (both started and warmed — every worker has loaded the compiled rig — before the clock
  starts), and the direct path in this process on a tenth of them.

Timings depend on the machine and its load: the figures that count are the ratios of the
same run.  Prints a table and, as the last line, one JSON object.
``HYDRODIAG_LIGHT=1`` runs the light form (CI).
"""

from __future__ import annotations

import json
import multiprocessing
import os
import statistics
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from typing import Any

import numpy as np

from benchmarks.diagnose_cases import FULL, random_records
from diagnostics.batch import diagnose_many
from diagnostics.condition_interval import check_singles
from diagnostics.diagnose import diagnose
from diagnostics.evidence_at_fit import evidence_at_fit
from diagnostics.fastpath.maps import fast_maps
from diagnostics.goodness import goodness_of_fit
from diagnostics.isolability import isolability
from diagnostics.measurement import MeasurementRecord
from diagnostics.observations import observe
from diagnostics.ranking import Ranker
from sim.rigs import Rig, reference_rig


def _per_record(rig: Rig, records: Sequence[MeasurementRecord], method: str) -> list[float]:
    out = []
    for rec in records:
        t = time.perf_counter()
        diagnose(rig, [rec], method=method)  # type: ignore[arg-type]
        out.append(time.perf_counter() - t)
    return out


def _rate(run: Callable[[], Any], n: int) -> float:
    t = time.perf_counter()
    run()
    return n / (time.perf_counter() - t)


def _warm(executor: Executor, rig: Rig, records: Sequence[MeasurementRecord]) -> None:
    """Every worker loads the rig and its kernels (one small chunk each, twice over)."""
    diagnose_many(rig, list(records[:8]), executor=executor, chunk_size=1)


def _stages(rig: Rig, records: Sequence[MeasurementRecord]) -> dict[str, float]:
    """Median time [ms] of each stage of a fast diagnosis at a new condition: the maps,
    σ (the healthy readings at the moved conditions), the fits, the single faults checked
    at their estimates (:func:`~diagnostics.condition_interval.check_singles`), the
    evidences moved there (:func:`~diagnostics.evidence_at_fit.evidence_at_fit`),
    isolability, goodness of fit, and the whole :func:`diagnose` once the maps are cached
    (which adds the intervals' widening, the profiles, the direct inversions, the ratio
    index and the notes)."""
    parts: dict[str, list[float]] = {k: [] for k in (
        "maps", "sigma", "fits", "checks", "evidence_at_fit", "isolability", "goodness",
        "diagnose_maps_cached")}
    for rec in records:
        obs = [observe(rec, rig)]
        t0 = time.perf_counter()
        fast_maps(rig, obs[0].condition)
        t1 = time.perf_counter()
        ranker = Ranker(rig, obs, 0.002, "fast")
        t2 = time.perf_counter()
        fits = ranker.rank()
        t3 = time.perf_counter()
        checks = check_singles(ranker, fits)
        t4 = time.perf_counter()
        evidence_at_fit(ranker, fits, checks)
        t5 = time.perf_counter()
        isolability(ranker, fits, 0.002, checks.chi2)
        t6 = time.perf_counter()
        goodness_of_fit(ranker, fits, at_fit=checks.chi2)
        t7 = time.perf_counter()
        diagnose(rig, [rec], method="fast")  # maps cached now: everything but the maps
        t8 = time.perf_counter()
        for key, dt in (("maps", t1 - t0), ("sigma", t2 - t1), ("fits", t3 - t2),
                        ("checks", t4 - t3), ("evidence_at_fit", t5 - t4),
                        ("isolability", t6 - t5), ("goodness", t7 - t6),
                        ("diagnose_maps_cached", t8 - t7)):
            parts[key].append(dt)
    return {k: round(1e3 * statistics.median(v), 3) for k, v in parts.items()}


def main() -> None:
    light = os.environ.get("HYDRODIAG_LIGHT") == "1"
    n_single, n_warm, n_batch = (40, 30, 500) if light else (200, 100, 10_000)
    started = time.perf_counter()
    rig = reference_rig()
    rng = np.random.default_rng(9)
    # the first diagnosis of each path compiles or loads everything (not timed)
    first = random_records(rng, rig, 2, [FULL])
    t = time.perf_counter()
    diagnose(rig, [first[0]], method="fast")
    cold_fast = time.perf_counter() - t
    diagnose(rig, [first[1]], method="direct")
    new_fast = _per_record(rig, random_records(rng, rig, n_single, [FULL]), "fast")
    new_direct = _per_record(rig, random_records(rng, rig, n_single, [FULL]), "direct")
    stages = _stages(rig, random_records(rng, rig, n_single, [FULL]))
    (again,) = random_records(rng, rig, 1, [FULL])
    warm_fast = _per_record(rig, [again] * (n_warm + 1), "fast")[1:]
    warm_direct = _per_record(rig, [again] * (n_warm + 1), "direct")[1:]
    batch = random_records(rng, rig, n_batch, [FULL])
    n_direct = max(n_batch // 10, 20)
    rates = {"direct_in_process": _rate(lambda: diagnose_many(rig, batch[:n_direct],
                                                              method="direct"), n_direct),
             "in_process": _rate(lambda: diagnose_many(rig, batch), n_batch)}
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        _warm(pool, rig, batch)
        rates["process_pool_2"] = _rate(lambda: diagnose_many(rig, batch, executor=pool),
                                        n_batch)
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        dask = client.get_executor()
        _warm(dask, rig, batch)
        rates["dask_2_workers"] = _rate(
            lambda: diagnose_many(rig, batch, executor=dask, chunk_size=max(n_batch // 32, 1)),
            n_batch)

    runs = {"new_fast": new_fast, "new_direct": new_direct, "warm_fast": warm_fast,
            "warm_direct": warm_direct}
    med = {k: 1e3 * statistics.median(v) for k, v in runs.items()}
    best = {k: 1e3 * min(v) for k, v in runs.items()}
    load = os.getloadavg()[0]
    print(f"diagnose() on the paper-002 rig, all seven readings ({'light' if light else 'full'}"
          f" form; load average {load:.1f})")
    print(f"{'case (median; best)':<30}{'fast [ms]':>16}{'direct [ms]':>16}{'speed-up':>10}")
    for case, key in (("new condition every record", "new"), ("warm (same record)", "warm")):
        f, d = med[f"{key}_fast"], med[f"{key}_direct"]
        fb, db = best[f"{key}_fast"], best[f"{key}_direct"]
        print(f"{case:<30}{f:>9.2f}; {fb:<5.2f}{d:>10.2f}; {db:<5.2f}{d / f:>9.1f}x")
    print("fast path at a new condition, median per stage [ms]: "
          + ", ".join(f"{k} {v:.2f}" for k, v in stages.items()))
    print(f"first diagnosis of the process (kernels loaded from the cache a run before "
          f"left, or compiled when there is none): "
          f"{1e3 * cold_fast:.0f} ms")
    print(f"\nbatch of {n_batch} records (direct: {n_direct})")
    print(f"{'where':<34}{'records/s':>11}")
    for k, v in rates.items():
        print(f"{k:<34}{v:>11.1f}")
    print(json.dumps({
        "light": light, "records_new": n_single, "records_warm": n_warm, "batch": n_batch,
        "new_condition_ms": {"fast": round(med["new_fast"], 3),
                             "direct": round(med["new_direct"], 3),
                             "speedup": round(med["new_direct"] / med["new_fast"], 2)},
        "warm_ms": {"fast": round(med["warm_fast"], 3), "direct": round(med["warm_direct"], 3),
                    "speedup": round(med["warm_direct"] / med["warm_fast"], 2)},
        "best_ms": {k: round(v, 3) for k, v in best.items()},
        "fast_new_condition_stages_ms": stages,
        "cold_first_ms": round(1e3 * cold_fast, 1),
        "batch_records_per_s": {k: round(v, 1) for k, v in rates.items()},
        "batch_speedup_in_process": round(rates["in_process"] / rates["direct_in_process"], 2),
        "targets_met": {"new_le_1ms": med["new_fast"] <= 1.0, "warm_le_0_5ms":
                        med["warm_fast"] <= 0.5},
        "load_average": round(load, 2), "wall_s": round(time.perf_counter() - started, 1),
    }))


if __name__ == "__main__":
    main()
