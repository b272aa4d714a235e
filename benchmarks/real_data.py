"""Real measured data study (issue 12): pump leakage on the ZeMA rig, no label used in fitting.

Reads ``data/real/uci-hydraulic-zema/`` of the shared data (``HYDRODIAG_SHARED``, else
``../shared``, else ``/work/shared``), imports every cycle through the import path
(:mod:`diagnostics.real.zema`), estimates the extra leakage conductance per cycle
(:mod:`diagnostics.real.leakage`) and scores it against the labels.  Also printed: the
viscosity-normalised baseline ``G·μ(θ)`` (what paper 000 eq. 6 with Cs = G·μ/D would track),
and change points of the estimate over the cycles against the leakage label's switches.

The V32HL56 piston-pump map (``data/real/pump-efficiency-V32HL56/``): per displacement
setting, the derived capacity (intercept, Toet, Vimax; one temperature, assumed), the
piston loss family (:mod:`diagnostics.pump.piston`) with one speed left out at a time next to
a plain quadratic in (Δp, n), with the flow loss fitted to Qth − QOut and to the measured
case-drain flow.

``HYDRODIAG_LIGHT=1``: every 4th cycle; the map in full (it is small).
Run: ``make real-data``.  Last line: JSON.
"""

from __future__ import annotations

import json
import os
import time

import numpy as np

from benchmarks import real_pump_map
from diagnostics.real.leakage import (
    LeakageScore,
    change_points,
    cycle_point,
    leakage_estimates,
    score_leakage,
)
from diagnostics.real.zema import load_1hz, read_records, zema_root
from sim.components.gear_pump import dynamic_viscosity
from sim.fluid import Fluid

#: A detected change point within this many cycles of a label switch is a hit [-].
TOLERANCE = 5


def _row(name: str, s: LeakageScore) -> str:
    cw = ", ".join(f"{v:+.2f}" for v in s.cooler_within)
    aw = ", ".join(f"{v:+.2f}" for v in s.accumulator_within)
    return (f"{name:34s} {s.spearman:6.3f} {s.ceiling:6.3f} {100 * s.fraction:6.1f} "
            f"{s.auroc_01:6.3f} {s.auroc_12:6.3f}  cooler [{cw}]  acc [{aw}]")


def pump_map() -> dict[str, object]:
    """The V32HL56 part (:mod:`benchmarks.real_pump_map`): print its tables, return figures."""
    return real_pump_map.pump_map()


def main() -> None:
    """Run the study and print the table and the JSON line."""
    light = os.environ.get("HYDRODIAG_LIGHT") == "1"
    root = zema_root()
    t0 = time.perf_counter()
    n_all = sum(1 for _ in (root / "profile.txt").open())
    cycles = list(range(1, n_all + 1, 4 if light else 1))
    data, labels = load_1hz(root, cycles)
    t_read = time.perf_counter() - t0
    records = read_records(data)
    t_import = time.perf_counter() - t0 - t_read
    points = [cycle_point(r) for r in records]
    est = leakage_estimates(points)
    t_est = time.perf_counter() - t0 - t_read - t_import

    theta = np.array([p.theta for p in points])
    mu = dynamic_viscosity(Fluid(), theta)
    score = score_leakage(est, labels.leakage, labels.cooler, labels.accumulator)
    baseline = score_leakage(est * mu, labels.leakage, labels.cooler, labels.accumulator)
    stable = labels.stable == 0
    score_stable = score_leakage(est[stable], labels.leakage[stable], labels.cooler[stable],
                                 labels.accumulator[stable])

    cps = change_points(est, min_size=10 if light else 20)
    step = 4 if light else 1
    switches = list(np.flatnonzero(np.diff(labels.leakage)) + 1)
    tol = max(1, TOLERANCE // step)
    hits = sum(1 for s in switches if any(abs(c - s) <= tol for c in cps))
    false = sum(1 for c in cps if not any(abs(c - s) <= tol for s in switches))

    med = {f"{int(c)}": {f"{int(k)}": float(np.median(est[(labels.cooler == c)
                                                           & (labels.leakage == k)]))
                         for k in (0, 1, 2)} for c in (3, 20, 100)}
    theta_by_cooler = {f"{int(c)}": float(theta[labels.cooler == c].mean()) for c in (3, 20, 100)}

    print(f"ZeMA hydraulic rig: {len(points)} cycles{' (light: every 4th)' if light else ''}, "
          f"1 Hz, from {root}")
    print("pump leakage estimate: extra leakage conductance G_est = (q_ref(θ) − q)/Δp, "
          "q_ref = 97.5 % envelope of the campaign's plateau flows within ±1 °C; no label used")
    print()
    print(f"{'estimate':34s} {'rho':>6s} {'ceil':>6s} {'%ceil':>6s} {'AUC01':>6s} {'AUC12':>6s}"
          "  within-leakage-class rank corr. (class 0, 1, 2)")
    print(_row("G_est (all cycles)", score))
    print(_row("G_est (stable flag 0 only)", score_stable))
    print(_row("G_est·μ(θ) (eq. 6 Cs-like baseline)", baseline))
    print()
    print("median G_est [1e-13 m³/(s·Pa)] by cooler (rows) and leakage class (columns); "
          "mean oil temperature")
    for c in ("3", "20", "100"):
        vals = "  ".join(f"{med[c][k] * 1e13:7.3f}" for k in ("0", "1", "2"))
        print(f"  cooler {c:>3s} %  {vals}    θ = {theta_by_cooler[c]:.1f} °C")
    print()
    print(f"change points of G_est over cycles: {len(cps)} found; leakage-label switches "
          f"{len(switches)}, detected within ±{tol} cycle rows: {hits}; "
          f"change points not at a leakage switch: {false}")
    print(f"time: read {t_read:.2f} s, import {t_import:.2f} s, estimate {t_est:.2f} s "
          f"(estimate/import ratio {t_est / t_import:.2f})")
    figures = {
        "study": "real_data", "light": light, "cycles": len(points),
        "spearman": score.spearman, "spearman_ceiling": score.ceiling,
        "fraction_of_ceiling": score.fraction, "auroc_0_1": score.auroc_01,
        "auroc_1_2": score.auroc_12, "cooler_within": list(score.cooler_within),
        "accumulator_within": list(score.accumulator_within),
        "worst_confound": score.worst_confound,
        "stable_only": {"spearman": score_stable.spearman,
                        "fraction_of_ceiling": score_stable.fraction,
                        "auroc_0_1": score_stable.auroc_01, "auroc_1_2": score_stable.auroc_12,
                        "worst_confound": score_stable.worst_confound},
        "mu_normalised": {"spearman": baseline.spearman, "fraction_of_ceiling": baseline.fraction,
                          "auroc_0_1": baseline.auroc_01, "auroc_1_2": baseline.auroc_12,
                          "worst_confound": baseline.worst_confound},
        "median_by_cooler_and_class": med, "theta_by_cooler": theta_by_cooler,
        "change_points": len(cps), "leakage_switches": len(switches),
        "switches_detected": hits, "change_points_not_at_switch": false,
        "targets": {"fraction_of_ceiling_ge_0.95": score.fraction >= 0.95,
                    "auroc_ge_0.95": min(score.auroc_01, score.auroc_12) >= 0.95,
                    "confound_lt_0.1": score.worst_confound < 0.1},
        "time_ratio_estimate_to_import": t_est / t_import,
        "pump_map": pump_map(),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
