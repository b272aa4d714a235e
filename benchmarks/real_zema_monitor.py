"""The pump leak as the service answers it, scored on the ZeMA campaign (issue 12).

Called by :func:`benchmarks.real_zema.zema` (``make real-data``).  The cycles go through
:func:`diagnostics.real.monitor.monitor_pump_leak` — what ``POST /rigs/{rig_id}/pump-leak``
and ``hydrodiag pump-leak`` run on stored cycles, with their defaults (τ = 3.5 s, ±1 °C,
the slope and shunt fitted on the cycles with the most working plateaus) — and its answer
is scored: the leak size against the pump-leakage label (Spearman, its fraction of the
ceiling the label's ties allow, AUROC 0-1 and 1-2, the rank correlation with the cooler and
accumulator labels within each leakage class), the leaking flag against label > 0, and the
steps of the leak against the label's switches (a step within ``TOLERANCE`` cycles of a
switch finds it).  Labels only score.
"""

from __future__ import annotations

import numpy as np

from diagnostics.real.leakage import score_leakage
from diagnostics.real.monitor import monitor_pump_leak
from diagnostics.real.zema import ZemaLabels
from diagnostics.timeseries import SeriesRecord
from sim.fluid import Fluid

__all__ = ["service_estimate"]

#: a step within this many cycles of a label switch finds it (every 4th cycle: 1) [-]
TOLERANCE = 1


def service_estimate(records: list[SeriesRecord], labels: ZemaLabels, light: bool
                     ) -> dict[str, object]:
    """Print and return the service's estimate's figures on ``records``."""
    m = monitor_pump_leak(records, Fluid(), min_segment=5 if light else 10)
    size = np.array([c.size for c in m.cycles])
    s = score_leakage(size, labels.leakage, labels.cooler, labels.accumulator)
    leaking = np.array([c.leaking for c in m.cycles])
    agree = float(np.mean(leaking == (np.asarray(labels.leakage) > 0)))
    switches = list(np.flatnonzero(np.diff(labels.leakage)) + 1)
    steps = [sh.index for sh in m.shifts]
    found = sum(1 for w in switches if any(abs(c - w) <= TOLERANCE for c in steps))
    false = sum(1 for c in steps if not any(abs(c - w) <= TOLERANCE for w in switches))
    print()
    print("the service's answer (POST /rigs/{id}/pump-leak, hydrodiag pump-leak: "
          "diagnostics.real.monitor with its defaults; no label used)")
    print(f"  leak size K: Spearman {s.spearman:.3f} ({100 * s.fraction:.1f} % of the "
          f"{s.ceiling:.3f} ceiling), AUROC {s.auroc_01:.3f} / {s.auroc_12:.3f}, within a "
          "leakage class: cooler " + " ".join(f"{x:+.2f}" for x in s.cooler_within)
          + ", accumulator " + " ".join(f"{x:+.2f}" for x in s.accumulator_within))
    print(f"  leaking flag = label > 0 in {100 * agree:.2f} % of {len(m.cycles)} cycles; "
          f"steps of the leak {len(steps)}, label switches {len(switches)}, found within "
          f"±{TOLERANCE} cycle(s) {found}, steps not at a switch {false}")
    for note in m.notes:
        print(f"  note: {note}")
    return {"spearman": s.spearman, "fraction_of_ceiling": s.fraction,
            "auroc_0_1": s.auroc_01, "auroc_1_2": s.auroc_12,
            "cooler_within": list(s.cooler_within),
            "accumulator_within": list(s.accumulator_within),
            "worst_confound": s.worst_confound, "flag_agreement": agree,
            "steps": len(steps), "label_switches": len(switches), "switches_found": found,
            "steps_not_at_switch": false}
