"""The load-program part of the ZeMA study (issue 12): accumulator gas volume and valve lag.

Called by :func:`benchmarks.real_zema.zema` (``make real-data``); split from it by topic.

* Accumulator gas volume from the oil stored at the load steps
  (:mod:`diagnostics.real.accumulator`), the steps chosen by a rule fixed before scoring
  (:func:`~diagnostics.real.accumulator.upper_steps`), the pump line through the plateaus'
  settled flows (the gas relaxation time found for the leak estimate), with the label-free
  agreement of single steps and, for scoring only, how far apart the classes lie.
* Accumulator pre-charge per cycle (:mod:`diagnostics.real.precharge`): the accumulator's
  volume one number of the rig, the pre-charge per cycle from the four load steps with the
  accumulator empty below it (hot oil raises the gas's pressure above the lower plateaus),
  referred to 20 °C.
* Valve switching time from the pressure step at the valve's switching
  (:mod:`diagnostics.real.switching`), at 1 Hz and on the raw 100 Hz cycles.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy.stats import spearmanr

from diagnostics.real.accumulator import gas_volumes, step_volumes
from diagnostics.real.precharge import fit_precharge, refer_precharge
from diagnostics.real.scoring import ClassScore, score_classes
from diagnostics.real.switching import crossing_time, switching_lags, switching_times
from diagnostics.real.zema import (
    FULLRES_CYCLES,
    ZemaLabels,
    load_1hz,
    read_fullres,
    read_records,
    zema_root,
)
from diagnostics.robust import mad_sigma
from diagnostics.timeseries import SeriesRecord

__all__ = ["accumulator", "valve_lag"]

Arr = npt.NDArray[np.float64]


def _class_row(name: str, s: ClassScore) -> str:
    auc = " ".join(f"{k}:{v:.3f}" for k, v in s.auroc.items())
    conf = "  ".join(f"{k} [{', '.join(f'{x:+.2f}' for x in v)}]" for k, v in s.within.items())
    return (f"{name:30s} n={s.n:4d} ρ={s.spearman:+.3f} ceil={s.ceiling:.3f} "
            f"({100 * s.fraction:5.1f} %)  AUROC {auc}\n{'':32s}within-class ρ: {conf}")


def _separation(v: Arr, labels: Arr, a: float, b: float) -> dict[str, float]:
    """How far apart two pre-charge classes lie against their own scatter (scoring only).

    d' = (median_b − median_a)/σ with σ the pooled robust spread (1.4826·MAD) of the two
    classes; ``Φ(d'/√2)`` is the AUROC two normal classes that far apart would give, and
    ``(b/a)^(1/n)`` the ratio of gas volumes the polytropic law expects at equal V0 [-].
    """
    xa, xb = v[(labels == a) & np.isfinite(v)], v[(labels == b) & np.isfinite(v)]
    ma, mb = float(np.median(xa)), float(np.median(xb))
    sa = mad_sigma(xa)
    sb = mad_sigma(xb)
    sig = math.sqrt(0.5 * (sa * sa + sb * sb))
    d = (mb - ma) / sig
    return {"measured_ratio": mb / ma, "expected_ratio": (b / a) ** (1.0 / 1.4),
            "relative_spread": sig / ma, "d_prime": d,
            "gaussian_auroc": 0.5 * math.erfc(-d / 2.0)}


def accumulator(records: list[SeriesRecord], labels: ZemaLabels,
                 relaxation: float) -> dict[str, object]:
    others = {"leakage": labels.leakage, "cooler": labels.cooler, "valve": labels.valve}
    print()
    print("accumulator: gas volume at 150 bar from the oil stored at the load steps "
          "(polytropic n = 1.4), scored against the pre-charge label [bar]")
    out: dict[str, object] = {}
    per = np.column_stack([gas_volumes(records, steps=(k,)) for k in range(4)])
    ok = np.all(np.isfinite(per), axis=1)
    agree = np.asarray(spearmanr(per[ok]).statistic, dtype=np.float64)
    print("  label-free: rank correlation, cycle by cycle, of the gas volumes of single steps "
          "(steps 0-3: 146→156, 156→166, 166→156, 156→151 bar)")
    for k in range(4):
        print("    step " + str(k) + "  " + "  ".join(f"{x:+.3f}" for x in agree[k]))
    per_step = {}
    for k in range(4):
        sk = score_classes(per[:, k], labels.accumulator, others)
        per_step[str(k)] = sk.as_dict()
        print(_class_row(f"step {k} alone (record only)", sk))
    raw = gas_volumes(records, temperature=None)
    s_raw = score_classes(raw, labels.accumulator, others)
    print(_class_row("upper steps, no gas temperature", s_raw))
    plain = gas_volumes(records)
    s_plain = score_classes(plain, labels.accumulator, others)
    print(_class_row("upper steps, gas at 20 °C, means", s_plain))
    vg = gas_volumes(records, relaxation=relaxation)
    s = score_classes(vg, labels.accumulator, others)
    print(_class_row(f"upper, 20 °C, settled τ={relaxation:.1f} s", s))
    print("  (τ: the gas relaxation time found for the leak estimate, label-free; the pump line "
          "q_ss through the plateaus' settled flows)")
    med = {f"{a:g}": float(np.nanmedian(vg[labels.accumulator == a])) * 1e3
           for a in (90.0, 100.0, 115.0, 130.0)}
    print("  median gas volume [l] by pre-charge: "
          + ", ".join(f"{k} bar: {v:.4f}" for k, v in med.items()))
    sep = {f"{a:g}<{b:g}": _separation(vg, labels.accumulator, a, b)
           for a, b in ((90.0, 100.0), (100.0, 115.0), (115.0, 130.0))}
    print("  class separation (scoring only): measured / polytropic ratio of medians, robust "
          "spread, d', AUROC of two normal classes that far apart")
    for name, v in sep.items():
        print(f"    {name:8s} ratio {v['measured_ratio']:.3f} / {v['expected_ratio']:.3f}  spread "
              f"{100 * v['relative_spread']:.1f} %  d' {v['d_prime']:.2f}  "
              f"Φ(d'/√2) {v['gaussian_auroc']:.3f}")
    n_ok = int(np.isfinite(vg).sum())
    print(f"  cycles with the four load steps: {n_ok} of {vg.size} (the others left the load "
          "program: relief valve holding the middle plateaus)")
    pre = _precharge(records, labels, relaxation, others)
    out.update({"precharge": pre, "upper_steps": s.as_dict(), "relaxation_s": relaxation,
                "upper_steps_plateau_means": s_plain.as_dict(),
                "upper_steps_no_temperature": s_raw.as_dict(),
                "step_rule": "steps between plateaus in the upper half of the cycle's "
                             "working pressures (fixed before scoring)",
                "step_agreement_spearman": agree.tolist(),
                "per_step": per_step, "median_gas_l": med, "separation": sep,
                "cycles_scored": n_ok})
    return out


def _precharge(records: list[SeriesRecord], labels: ZemaLabels, relaxation: float,
               others: dict[str, Arr]) -> dict[str, object]:
    """Pre-charge per cycle where the accumulator empties (:mod:`diagnostics.real.precharge`)."""
    steps = [step_volumes(r, relaxation=relaxation) for r in records]
    fit = fit_precharge([s if len(s) == 4 else None for s in steps])
    theta = np.array([float(np.mean(r.channel("oil_temperature"))) for r in records])
    p20 = refer_precharge(fit.p0, theta)
    s = score_classes(p20, labels.accumulator, others)
    print()
    print("accumulator pre-charge per cycle: V(p) = V0·min(1, (p0/p)^(1/1.4)), empty below p0; "
          "V0 one number of the rig, p0 per cycle, least squares over the four load steps "
          "(no label); p0 referred to 20 °C with the cycle's oil temperature")
    print(f"  V0 = {fit.v0 * 1e3:.3f} l, rms residual {fit.rms * 1e6:.2f} ml per step, "
          f"{fit.at_grid_edge} cycles at the grid's edge")
    print(_class_row("p0 at 20 °C (all four steps)", s))
    med = {f"{a:g}": float(np.nanmedian(p20[labels.accumulator == a])) / 1e5
           for a in (90.0, 100.0, 115.0, 130.0)}
    hot = {f"{a:g}": float(np.nanmedian(fit.p0[labels.accumulator == a])) / 1e5
           for a in (90.0, 100.0, 115.0, 130.0)}
    print("  median p0 [bar] by pre-charge label, at 20 °C: "
          + ", ".join(f"{k}: {v:.1f}" for k, v in med.items())
          + "; at the gas temperature: " + ", ".join(f"{k}: {v:.1f}" for k, v in hot.items()))
    return {"score": s.as_dict(), "v0_l": fit.v0 * 1e3, "rms_ml": fit.rms * 1e6,
            "at_grid_edge": fit.at_grid_edge, "median_p0_20C_bar": med,
            "median_p0_gas_temperature_bar": hot}


def valve_lag(records: list[SeriesRecord], labels: ZemaLabels) -> dict[str, object]:
    print()
    print("valve: equivalent switching time t* of the relief→load pressure step (s 9-11), "
          "lag behind the campaign's 1 % quantile; scored against the valve condition "
          "(the lag grows as it falls)")
    t = switching_times(records)
    lag = switching_lags(t)
    others = {"leakage": labels.leakage, "cooler": labels.cooler,
              "accumulator": labels.accumulator}
    s = score_classes(lag, labels.valve, others, decreasing=True)
    print(_class_row("lag (1 Hz block means)", s))
    med = {f"{v:g}": float(np.nanmedian(lag[labels.valve == v])) * 1e3
           for v in (100.0, 90.0, 80.0, 73.0)}
    print("  median lag [ms] by valve condition: "
          + ", ".join(f"{k} %: {v:.0f}" for k, v in med.items()))
    # the raw 100 Hz cycles: same t* from the raw samples as from their 1 s means?
    path = zema_root() / "fullres_samples" / "jeremiafourie" / "testing_sample.csv"
    raw = read_fullres(path, FULLRES_CYCLES, sensors=("PS1", "PS2"))
    t_raw = switching_times(raw)
    data, lab = load_1hz(zema_root(), list(FULLRES_CYCLES), sensors=("PS1",))
    t_1hz = switching_times(read_records(data))
    diff = float(np.max(np.abs(t_raw - t_1hz)))
    s_raw = score_classes(t_raw, lab.valve, {}, decreasing=True)
    print(f"  raw 100 Hz cycles {list(FULLRES_CYCLES)}: t* raw vs 1 Hz differ by at most "
          f"{diff * 1e3:.3g} ms; ρ(t*, valve, decreasing) on these {len(raw)} cycles = "
          f"{s_raw.spearman:+.3f} (ceiling {s_raw.ceiling:.3f})")
    rows = []
    for r, c, tr, v in zip(raw, FULLRES_CYCLES, t_raw, lab.valve, strict=True):
        p = r.channel("p_pump")
        hi, lo = float(p[200:900].mean()), float(p[1200:1900].mean())
        opening = crossing_time(r, 5.0e5)
        p90 = crossing_time(r, lo + 0.9 * (hi - lo), channel="p_pump", rising=False)
        p10 = crossing_time(r, lo + 0.1 * (hi - lo), channel="p_pump", rising=False)
        rows.append({"cycle": c, "valve": float(v), "t_star_s": float(tr),
                     "ps2_opening_s": opening, "ps1_fall_10_90_ms": (p10 - p90) * 1e3})
        print(f"    cycle {c:5d}  valve {v:4.0f} %  t* = {tr:.3f} s   PS2 through 5 bar at "
              f"{opening:.3f} s   PS1 fall 90→10 % {1e3 * (p10 - p90):4.0f} ms")
    s_open = score_classes(np.array([r["ps2_opening_s"] for r in rows]), lab.valve, {},
                           decreasing=True)
    by_valve = {f"{v:g}": float(np.median([r["ps2_opening_s"] for r in rows
                                           if r["valve"] == v])) for v in (100.0, 90.0, 80.0)}
    print(f"  PS2 opening at native rate: ρ = {s_open.spearman:+.3f} (ceiling "
          f"{s_open.ceiling:.3f}), AUROC {s_open.auroc}; median opening by valve "
          + ", ".join(f"{k} %: {v:.3f} s" for k, v in by_valve.items()))
    return {"fullres": rows, "fullres_opening": s_open.as_dict(),
            "fullres_opening_median_s": by_valve, "lag": s.as_dict(), "median_lag_ms": med,
            "fullres_max_diff_ms": diff * 1e3,
            "fullres_spearman": s_raw.spearman, "fullres_ceiling": s_raw.ceiling,
            "fullres_cycles": len(raw)}
