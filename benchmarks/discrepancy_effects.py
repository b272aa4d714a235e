"""Hidden-effect cases for chosen library entries, with what the workflow reported.

Run: ``python -m benchmarks.discrepancy_effects`` (``make discrepancy-effects``). The
cases are the hidden-effect bench's own (:func:`benchmarks.discrepancy_study._case`:
three cycles at 2.1/4.2/6.3 kN, 40/50/60 °C, 80/90/100 % pump speed, the 6.3 kN record
held out; sizes from :func:`~benchmarks.discrepancy_study.calibrate`), for a few effects
instead of the whole library, reporting per case the named effects, the competing and
ambiguous ones, each balance's choice before the output-error confirmation, the fitted
strength, and whether the named effect's stated 95 % interval holds the hidden value
(``interval_coverage``: the fraction of the cases naming it). ``HYDRODIAG_EFFECTS``
(comma list; default the rig-wide entries: viscosity law, entrained air, relief
override, unsteady line friction), ``HYDRODIAG_SEEDS`` (default 5), ``HYDRODIAG_SIZES``
(σ, default 4,8,16; unsteady line friction's size is the peak difference at valve port
B, switch transients included, where 1000 σ ≈ k3 = 0.1, so its sizes are better given as
250,500,1000,2000); a case whose simulation fails (solver limit) is counted as
``failed``, as in the bench; ``HYDRODIAG_LIGHT=1``: the viscosity law at 16σ, one seed.
Seeds are 1..N (case seed 1000·s + 7, as the bench). Everything is SIMULATED. Prints a
table and, as its last line, one JSON object.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections import Counter
from typing import Any

from benchmarks.discrepancy_study import (
    _case,
    _doc_with,
    _median,
    calibrate,
    score,
    truth_ratio,
)
from diagnostics.discrepancy.synthetic import NOISE
from diagnostics.discrepancy.workflow import gap_ratio
from sim.errors import SimulationError, SolverLimitError

LIGHT = os.environ.get("HYDRODIAG_LIGHT") == "1"
DEFAULT = "viscosity_law,entrained_air,relief_override,line_unsteady_friction"
EFFECTS = os.environ.get("HYDRODIAG_EFFECTS", "viscosity_law" if LIGHT else DEFAULT).split(",")
SEEDS = int(os.environ.get("HYDRODIAG_SEEDS", "1" if LIGHT else "5"))
SIZES = [float(s) for s in os.environ.get("HYDRODIAG_SIZES", "16" if LIGHT else "4,8,16")
         .split(",")]


def case(effect: str, size: float, strength: float, seed: int) -> dict[str, Any]:
    """One hidden-effect case and what the workflow reported."""
    t0 = time.perf_counter()
    try:
        d = _case(_doc_with(effect, strength), 1000 * seed + 7)
    except (SimulationError, SolverLimitError) as exc:  # as the bench: a failed case
        return {"effect": effect, "size": size, "seed": seed, "strength": strength,
                "outcome": "failed", "named": [], "fitted": {}, "competing": [],
                "ambiguity": [], "chosen": {}, "verdict": f"failed: {exc}",
                "seconds": time.perf_counter() - t0}
    out: dict[str, Any] = {
        "effect": effect, "size": size, "seed": seed, "strength": strength,
        "outcome": score(d, effect), "named": [n.name for n in d.named],
        "fitted": {n.name: n.value for n in d.named},
        "intervals": {n.name: list(n.interval) for n in d.named},
        "competing": sorted({m for n in d.named for g in n.competing for m in g}),
        "ambiguity": sorted({m for n in d.named for g in n.ambiguity for m in g}),
        "chosen": {s.balance: [t.effect for t in s.chosen.terms]
                   for s in d.selections if s.chosen is not None},
        "verdict": d.verdict}
    if d.named:  # as the study: against the noise-free truth, and against the noisy data
        out["rmse_ratio"] = truth_ratio(d, _doc_with(effect, strength))
        out["rmse_ratio_vs_data"] = gap_ratio(d.gap_before, d.gap_after, NOISE)
    out["seconds"] = time.perf_counter() - t0
    return out


def main() -> None:
    t_start = time.perf_counter()
    rows: list[dict[str, Any]] = []
    cases: list[dict[str, Any]] = []
    # baseline of the timings: one no-effect case of the same design, in this run
    t0 = time.perf_counter()
    _case(_doc_with(None), 5007)
    null_seconds = time.perf_counter() - t0
    for effect in EFFECTS:
        unit = calibrate(effect)
        for size in SIZES:
            strength = size * unit
            if not math.isfinite(strength):
                rows.append({"effect": effect, "size_sigma": size, "n": 0,
                             "skipped": "no steady-motion signature on the design"})
                continue
            done = [case(effect, size, strength, s) for s in range(1, SEEDS + 1)]
            cases += done
            n = len(done)
            counts = Counter(c["outcome"] for c in done)
            chosen = sum(effect in [e for v in c["chosen"].values() for e in v] for c in done)
            fit = [abs(c["fitted"][effect] / strength - 1) for c in done
                   if effect in c["fitted"]]
            # does the stated 95 % interval of the named effect hold the hidden value?
            held = [c["intervals"][effect][0] <= strength <= c["intervals"][effect][1]
                    for c in done if effect in c["intervals"]]
            rows.append({
                "effect": effect, "size_sigma": size, "strength": strength, "n": n,
                "exact": counts["exact"] / n, "group": counts["group"] / n,
                "wrong": counts["wrong"] / n, "none": counts["none"] / n,
                "failed": counts["failed"] / n,
                "chosen_by_a_balance": chosen / n,
                "median_fit_error": _median(fit),
                "interval_coverage": sum(held) / len(held) if held else None,
                "median_rmse_ratio": _median([c.get("rmse_ratio", math.nan) for c in done]),
                "named_instead": sorted({m for c in done for m in c["named"]} - {effect}),
                "median_seconds": _median([c["seconds"] for c in done]),
                "time_vs_null_case": (_median([c["seconds"] for c in done]) or 0.0)
                / null_seconds})
    print(f"{'effect':24s} {'σ':>4s} {'n':>3s} {'exact':>6s} {'group':>6s} {'wrong':>6s} "
          f"{'none':>5s} {'fail':>5s} {'chosen':>7s} {'fit err':>8s} {'in 95%':>6s} "
          f"{'RMSE ×':>7s} "
          f"{'t/null':>7s}  other names")
    for r in rows:
        if r["n"] == 0:
            print(f"{r['effect']:24s} {r['size_sigma']:4.0f}   0  skipped: {r['skipped']}")
            continue

        def f(x: float | None, fmt: str) -> str:
            return format(x, fmt) if x is not None else "—"

        print(f"{r['effect']:24s} {r['size_sigma']:4.0f} {r['n']:3d} {r['exact']:6.2f} "
              f"{r['group']:6.2f} {r['wrong']:6.2f} {r['none']:5.2f} {r['failed']:5.2f} "
              f"{r['chosen_by_a_balance']:7.2f} {f(r['median_fit_error'], '8.3f')} "
              f"{f(r['interval_coverage'], '6.2f')} "
              f"{f(r['median_rmse_ratio'], '7.2f')} {r['time_vs_null_case']:7.2f}  "
              f"{', '.join(r['named_instead']) or '—'}")
    load = os.getloadavg()[0]
    print(f"(simulated; seeds 1..{SEEDS}; t/null: median time per case over a no-effect case "
          f"of {null_seconds:.1f} s in this run; load average {load:.1f})")
    print(json.dumps({"study": "discrepancy_effects", "light": LIGHT, "seeds": SEEDS,
                      "rows": rows, "load_average": load, "null_case_seconds": null_seconds,
                      "seconds": time.perf_counter() - t_start}))


if __name__ == "__main__":
    main()
