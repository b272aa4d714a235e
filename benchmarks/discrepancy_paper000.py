"""The paper-000 case of the discrepancy workflow: hidden pump-slip dynamics in field records.

Run: ``python -m benchmarks.discrepancy_paper000`` (``make discrepancy-paper000``).
``HYDRODIAG_LIGHT=1`` runs 2 seeds per cell (CI); ``HYDRODIAG_SEEDS=N`` sets the seeds
(default 20).

Everything is SIMULATED (:mod:`diagnostics.pump.field_record`): duty cycles of the mast-foot /
jib movements of paper 000 §3.2 (stand-by 11-20 bar, lowering 90-110 bar, raising 130-160
bar, steps over 0.15-0.4 s), 60 s each, sampled every 30 ms, flowmeter ±1 % of reading per
sample.  Per case, two records at 1467 rpm train the workflow
(:func:`diagnostics.discrepancy.field_case.discover_field`, starting from the base model),
and one record at 1961 rpm — the edge of the field speeds — is held out.

Cells: a hidden side-plate lag τ = 0.1, 0.3, 1.0 s; a hidden slip hysteresis h = 0.3; no
hidden effect.  Figures: the exact-name rate, wrong-name rate, fitted coefficient against
the truth, and the held-out flow gap *after the pressure steps* before/after (RMSE against
the measured flow, and against the noise-free flow, which the generator keeps).  Timing:
one discovery in units of one base-model prediction of a record, both measured in this run.

Prints a table and, as its last line, one JSON object with the figures.
"""

from __future__ import annotations

import json
import os
import time
from typing import Any

import numpy as np

from diagnostics.discrepancy.field_case import discover_field
from diagnostics.pump.field import predict
from diagnostics.pump.field_record import HiddenEffects, generate_field_record
from sim.duty_cycle import rpm

LIGHT = os.environ.get("HYDRODIAG_LIGHT") == "1"
SEEDS = int(os.environ.get("HYDRODIAG_SEEDS", "2" if LIGHT else "20"))
DURATION = 60.0

#: cell → (hidden effects, the library entry that should be named, its parameter, truth)
CELLS: dict[str, tuple[HiddenEffects, str | None, str | None, float]] = {
    "lag 0.1 s": (HiddenEffects(side_plate_lag=0.1), "side_plate_lag", "side_plate_lag.tau", 0.1),
    "lag 0.3 s": (HiddenEffects(side_plate_lag=0.3), "side_plate_lag", "side_plate_lag.tau", 0.3),
    "lag 1.0 s": (HiddenEffects(side_plate_lag=1.0), "side_plate_lag", "side_plate_lag.tau", 1.0),
    "hysteresis 0.3": (HiddenEffects(hysteresis=0.3), "slip_hysteresis", "slip_hysteresis.h",
                       0.3),
    "no effect": (HiddenEffects(), None, None, 0.0),
}


def _case(effects: HiddenEffects, seed: int) -> dict[str, Any]:
    train = [generate_field_record(DURATION, effects=effects, seed=seed + k) for k in (0, 1)]
    held = generate_field_record(DURATION, effects=effects, seed=seed + 2, speed=rpm(1961))
    t0 = time.perf_counter()
    d = discover_field(train, held, max_nfev=10)
    elapsed = time.perf_counter() - t0
    g = d.gap("after steps")
    return {"named": d.named, "verdict": d.verdict, "fitted": d.fitted, "errors": d.errors,
            "lr": d.held_out_lr, "rmse_before": g.rmse_before, "rmse_after": g.rmse_after,
            "truth_before": g.truth_before, "truth_after": g.truth_after,
            "max_before": g.max_before, "max_after": g.max_after, "seconds": elapsed,
            "simulations": d.evaluations}


def _median(xs: list[float]) -> float | None:
    return float(np.median(xs)) if xs else None


def main() -> None:
    t_start = time.perf_counter()
    # baseline of the timing: one base prediction of a record (after a warm-up)
    rec = generate_field_record(DURATION, seed=1)
    predict(rec)
    t0 = time.perf_counter()
    predict(rec)
    t_predict = time.perf_counter() - t0
    print(f"paper-000 discrepancy case: {'LIGHT' if LIGHT else 'full'}, {SEEDS} seed(s) per "
          f"cell, {DURATION:g} s records (SIMULATED), train 2 × 1467 rpm, held out 1961 rpm; "
          f"load average {os.getloadavg()[0]:.1f}")
    print(f"{'cell':15s} {'n':>3s} {'exact':>6s} {'wrong':>6s} {'fitted (median)':>16s} "
          f"{'truth':>6s} {'RMSE after steps [L/min] before → after':>40s} "
          f"{'vs noise-free':>22s}")
    cells: dict[str, dict[str, Any]] = {}
    seconds: list[float] = []
    for cell, (effects, truth_name, key, truth) in CELLS.items():
        runs = [_case(effects, 100 * s + 1) for s in range(SEEDS)]
        seconds += [r["seconds"] for r in runs]
        exact = sum(r["named"] == ([truth_name] if truth_name else []) for r in runs)
        wrong = sum(bool(r["named"]) and r["named"] != [truth_name] for r in runs)
        fitted = [r["fitted"][key] for r in runs if key and key in r["fitted"]]
        named_runs = [r for r in runs if r["named"]]
        rb = _median([r["rmse_before"] for r in runs])
        ra = _median([r["rmse_after"] for r in named_runs]) if named_runs else rb
        tb = _median([r["truth_before"] for r in runs])
        ta = _median([r["truth_after"] for r in named_runs]) if named_runs else tb
        ratio = _median([r["truth_before"] / r["truth_after"] for r in named_runs
                         if r["truth_after"] > 0])
        row = {"n": SEEDS, "exact": exact / SEEDS, "wrong": wrong / SEEDS, "truth": truth,
               "fitted_median": _median(fitted),
               "fitted_relative_error_median": _median([abs(f / truth - 1) for f in fitted])
               if truth else None,
               "rmse_after_steps_before": rb, "rmse_after_steps_after": ra,
               "truth_rmse_after_steps_before": tb, "truth_rmse_after_steps_after": ta,
               "truth_rmse_ratio_when_named": ratio,
               "held_out_lr_median": _median([r["lr"] for r in runs])}
        cells[cell] = row
        lpm = 6e4
        fit_s = f"{row['fitted_median']:.3g}" if row["fitted_median"] is not None else "—"
        print(f"{cell:15s} {SEEDS:3d} {row['exact']:6.2f} {row['wrong']:6.2f} {fit_s:>16s} "
              f"{truth:6.3g} {(rb or 0) * lpm:19.4f} → {(ra or 0) * lpm:.4f}{'':>11s} "
              f"{(tb or 0) * lpm:9.5f} → {(ta or 0) * lpm:.5f}")
    t_disc = float(np.median(seconds))
    print(f"one discovery (median) = {t_disc / t_predict:.1f} base predictions of a 60 s record")
    hidden = [c for c, (_, name, _, _) in CELLS.items() if name]
    summary = {
        "light": LIGHT, "seeds_per_cell": SEEDS, "record_s": DURATION,
        "cells": cells,
        "exact_rate_hidden": float(np.mean([cells[c]["exact"] for c in hidden])),
        "false_discovery_rate": cells["no effect"]["wrong"],
        "lag_0.3_tau_median": cells["lag 0.3 s"]["fitted_median"],
        "lag_0.3_truth_rmse_ratio": cells["lag 0.3 s"]["truth_rmse_ratio_when_named"],
        "discovery_over_prediction_time": t_disc / t_predict,
        "load_average": os.getloadavg()[0],
        "wall_s": time.perf_counter() - t_start,
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
