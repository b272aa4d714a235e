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

import numpy as np

from benchmarks.real_zema import zema
from diagnostics.pump import (
    bench_from_frame,
    derived_capacity_intercept,
    derived_capacity_toet,
    derived_capacity_vimax,
)
from diagnostics.pump.levels import cluster_levels
from diagnostics.pump.piston import bench_frame, held_out_speed, read_efficiency_map
from diagnostics.real.leakage import (
    LeakageScore,
)
from diagnostics.real.zema import find_shared
from sim.errors import InputError

#: A detected change point within this many cycles of a label switch is a hit [-].
TOLERANCE = 5


def _row(name: str, s: LeakageScore) -> str:
    cw = ", ".join(f"{v:+.2f}" for v in s.cooler_within)
    aw = ", ".join(f"{v:+.2f}" for v in s.accumulator_within)
    return (f"{name:34s} {s.spearman:6.3f} {s.ceiling:6.3f} {100 * s.fraction:6.1f} "
            f"{s.auroc_01:6.3f} {s.auroc_12:6.3f}  cooler [{cw}]  acc [{aw}]")


def pump_map() -> dict[str, object]:
    """The V32HL56 part: print its table, return its figures."""
    path = find_shared() / "data" / "real" / "pump-efficiency-V32HL56" / "V32HL56-efficiency.csv"
    data = read_efficiency_map(path)
    idx, levels = cluster_levels(data.D, field="Displacement")
    print()
    print(f"V32HL56 piston-pump map: {len(data)} points, {levels.size} displacement settings, "
          "one unrecorded temperature (50 °C assumed; enters nothing fitted here)")
    print(f"{'V [cm³/rev]':>11s} {'Toet %':>7s} {'icpt %':>7s} {'Vimax %':>7s} {'speeds':>6s} "
          f"{'flow S%':>7s} {'quad S%':>7s} {'drain S%':>8s} {'flow R²':>8s} {'torque S%':>9s} "
          f"{'quad S%':>7s}  flow terms | torque terms")
    rows: list[dict[str, object]] = []
    errs: list[tuple[float, float, float, float]] = []
    for k in range(levels.size):
        sub = data.subset(idx == k)
        D = float(np.mean(sub.D))
        bench = bench_from_frame(bench_frame(sub, 50.0))
        caps = {}
        for name, fn in (("toet", derived_capacity_toet), ("intercept",
                                                           derived_capacity_intercept),
                         ("vimax", derived_capacity_vimax)):
            try:
                caps[name] = 100.0 * (fn(bench).D / D - 1.0)
            except InputError as exc:
                caps[name] = float("nan")
                print(f"  {name} capacity refused at {D * 2e6 * np.pi:.1f} cm³/rev: {exc}")
        h = held_out_speed(sub, D)
        hd = held_out_speed(sub, D, target="drain")
        v = D * 2.0 * np.pi * 1e6
        print(f"{v:11.1f} {caps['toet']:+7.2f} {caps['intercept']:+7.2f} {caps['vimax']:+7.2f} "
              f"{h.speeds:6d} {h.flow_S:7.3f} {h.flow_S_quadratic:7.3f} {hd.flow_S:8.3f} "
              f"{h.flow_R2:8.5f} {h.torque_S:9.3f} {h.torque_S_quadratic:7.3f}  "
              f"{'+'.join(h.flow_terms)} | {'+'.join(h.torque_terms)}")
        errs.append((h.flow_S, h.flow_S_quadratic, h.torque_S, h.torque_S_quadratic))
        rows.append({"displacement_cm3_rev": v, "capacity_pct_vs_file": caps,
                     "speeds": h.speeds, "flow_S_pct": h.flow_S, "flow_R2": h.flow_R2,
                     "flow_S_quadratic_pct": h.flow_S_quadratic,
                     "flow_R2_quadratic": h.flow_R2_quadratic,
                     "flow_S_drain_target_pct": hd.flow_S, "torque_S_pct": h.torque_S,
                     "torque_R2": h.torque_R2, "torque_S_quadratic_pct": h.torque_S_quadratic,
                     "flow_terms": list(h.flow_terms), "torque_terms": list(h.torque_terms)})
    print("S: rms error at the held-out speed, % of the setting's largest flow (torque); "
          "paper 001 reports pump flow S 0.26-0.43 % of full flow")
    return {"settings": rows,
            "targets": {"flow_S_le_0.3_all": all(f <= 0.3 for f, _, _, _ in errs),
                        "flow_no_worse_than_quadratic_all": all(f <= fq for f, fq, _, _ in errs),
                        "torque_no_worse_than_quadratic_all": all(
                            t <= tq for _, _, t, tq in errs)}}


def main() -> None:
    """Run the study and print the tables and the JSON line."""
    light = os.environ.get("HYDRODIAG_LIGHT") == "1"
    figures = zema(light)
    figures["pump_map"] = pump_map()
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
