"""The accumulator confound of the ZeMA leak estimate (issue 12): the accumulator's intake.

Called by :func:`benchmarks.real_zema.zema` (``make real-data``); split from it by topic.

The plateau-by-plateau leak size (:mod:`diagnostics.real.profile`) is recomputed with each
plateau's flow given back the oil the accumulator took in while the pressure still drifted
on the plateau (:func:`~diagnostics.real.precharge.stored_rate`): the rig's accumulator
volume ``V0`` and each cycle's pre-charge from the load steps
(:func:`~diagnostics.real.precharge.fit_precharge`, no label), the cycles that left the load
program given the pre-charge of the nearest cycle in record order that has one
(:func:`~diagnostics.real.precharge.cycle_precharges`, the rule fixed before scoring),
``n = 1.4`` (the module default).  Every nuisance value (leak threshold, healthy slope,
``λ``, profile, ``τ``) is found exactly as for the estimate without the correction.

Printed for scoring only: the correction's size per plateau and pre-charge class, and how
strongly the oil temperature and the accumulator label go together inside each leakage ×
cooler cell of the campaign (a residual temperature dependence of any estimate reads as an
accumulator confound there).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt
from scipy.stats import spearmanr

from diagnostics.real.accumulator import step_volumes
from diagnostics.real.leakage import LeakageScore, score_leakage
from diagnostics.real.precharge import cycle_precharges, fit_precharge
from diagnostics.real.profile import plateau_deficits, plateau_table, profile_sizes
from diagnostics.real.zema import ZemaLabels
from diagnostics.timeseries import SeriesRecord

__all__ = ["accumulator_corrected"]

Arr = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]


def accumulator_corrected(records: list[SeriesRecord], labels: ZemaLabels, leaking: Mask,
                          slope: float, tau: float, full: Mask,
                          mu_of: Callable[[Arr], Arr],
                          row: Callable[[str, LeakageScore], str]
                          ) -> tuple[LeakageScore, dict[str, object]]:
    """The leak size with the accumulator's intake given back; its score and figures."""
    steps = [step_volumes(r, relaxation=tau) for r in records]
    fit = fit_precharge([s if len(s) == 4 else None for s in steps])
    theta = np.array([float(np.mean(r.channel("oil_temperature"))) for r in records])
    pre = cycle_precharges(fit.p0, theta)
    table = plateau_table(records, relaxation=tau, precharge=pre, gas_volume=fit.v0)
    dk = plateau_deficits(table, ~leaking, slope)
    prof = profile_sizes(dk, table.pressure, mu_of(table.theta), table.theta, leaking, full)
    masks = {"all": np.ones_like(full), "on": full, "off": ~full}
    sc = {k: score_leakage(prof.size[m], labels.leakage[m], labels.cooler[m],
                           labels.accumulator[m]) for k, m in masks.items()}
    rates = table.intake if table.intake is not None else np.zeros_like(table.flow)
    print()
    print("accumulator intake given back on each plateau: q + d(V0 − V(p))/dt, V(p) = "
          "V0·min(1, (p0/p)^(1/1.4)), V0 and p0 per cycle from the load steps (no label); "
          "cycles that left the program: p0 of the nearest cycle that has one")
    print(f"  V0 = {fit.v0 * 1e3:.3f} l; cycles with their own p0: "
          f"{int(np.isfinite(fit.p0).sum())} of {len(records)}")
    med_rate = {}
    for a in (90.0, 100.0, 115.0, 130.0):
        v = np.nanmedian(rates[labels.accumulator == a], axis=0) * 6e4
        med_rate[f"{a:g}"] = [float(x) for x in v]
        print(f"  (scoring only) pre-charge {a:5.0f} bar: median intake per plateau "
              "[l/min] " + " ".join(f"{x:+.4f}" for x in v))
    print(row("K profile + intake (all) HEADLINE", sc["all"]))
    print(row("K profile + intake (on the program)", sc["on"]))
    print(row("K profile + intake (left the program)", sc["off"]))
    cells: dict[str, float] = {}
    for lk in (0.0, 1.0, 2.0):
        for c in (3.0, 20.0, 100.0):
            m = (labels.leakage == lk) & (labels.cooler == c)
            cells[f"{lk:g}/{c:g}"] = float(spearmanr(table.theta[m], labels.accumulator[m])[0])
    print("  (scoring only) rank correlation of the oil temperature with the accumulator label "
          "inside each leakage/cooler cell: "
          + "  ".join(f"{k}: {v:+.2f}" for k, v in cells.items()))
    print("  the campaign changes the accumulator in blocks of cycles while the oil "
          "temperature drifts: inside a cell a residual temperature dependence and an "
          "accumulator dependence cannot be told apart without labels")

    return sc["all"], {"all_cycles": sc["all"].figures(), "load_program_only": sc["on"].figures(),
                       "left_program_only": sc["off"].figures(), "v0_l": fit.v0 * 1e3,
                       "shunt_lambda_m3": prof.shunt,
                       "profile": [float(x) for x in prof.profile],
                       "median_intake_l_min_by_precharge": med_rate,
                       "theta_accumulator_rho_by_cell": cells,
                       "polytropic_n": 1.4,
                       "off_program_rule": "p0 (referred to 20 °C) of the nearest cycle in "
                                           "record order with a fit, at the cycle's own oil "
                                           "temperature"}
