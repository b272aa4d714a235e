"""The ZeMA part of the real-data study (issue 12): leakage, cooler confound, accumulator, valve.

Every estimate is computed from the measured cycles without any label; the labels of
``profile.txt`` only score (:mod:`diagnostics.real.scoring`).  Run through
``make real-data`` (:mod:`benchmarks.real_data`), which prints these tables and the pump
map's, and as its last line one JSON object with every figure.

1. Pump leakage (:mod:`diagnostics.real.leakage`), its score and change points.
2. The cooler confound: the orifice + laminar-shunt leak size (:mod:`diagnostics.real.shunt`)
   from each cycle's plateaus up to its first departure to the relief valve
   (``cycle_point(stop_at_relief=True)``: the 240 cycles that left the load program are
   compared on the first working plateau they share with every cycle, and corrected rather
   than flagged; their later plateaus follow a relief episode), and what else was tried,
   each *without* labels (labels only score): the
   temperature sensor of the envelope (TS1-TS4), the pressure law of the leak (G = Δq/Δp^a,
   a = 0, ½, 1), a viscosity exponent b (G·μ^b) fitted label-free inside change-point
   segments, and, as a sensitivity table only (never used to choose), G·μ^b on a grid.
3. Accumulator gas volume from the oil stored at the load steps
   (:mod:`diagnostics.real.accumulator`), the steps chosen by a rule fixed before scoring
   (:func:`~diagnostics.real.accumulator.upper_steps`), with the label-free agreement of
   the single steps and, for scoring only, how far apart the classes lie against their
   scatter.
4. Valve switching time from the pressure step at the valve's switching
   (:mod:`diagnostics.real.switching`), on all cycles at 1 Hz, and checked on the raw 100 Hz
   cycles of ``fullres_samples/``.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
import numpy.typing as npt
from scipy.stats import spearmanr

from diagnostics.real.accumulator import gas_volumes, step_volumes
from diagnostics.real.leakage import (
    LeakageScore,
    change_points,
    cycle_point,
    leakage_estimates,
    score_leakage,
)
from diagnostics.real.scoring import ClassScore, score_classes
from diagnostics.real.shunt import fit_relaxation, shunt_estimates
from diagnostics.real.switching import crossing_time, switching_lags, switching_times
from diagnostics.real.zema import (
    FULLRES_CYCLES,
    ZemaLabels,
    load_1hz,
    read_fullres,
    read_records,
    zema_root,
)
from diagnostics.timeseries import SeriesRecord
from sim.components.gear_pump import dynamic_viscosity
from sim.fluid import Fluid

__all__ = ["zema"]

Arr = npt.NDArray[np.float64]

#: A detected change point within this many cycles of a label switch is a hit [-].
TOLERANCE = 5


def _row(name: str, s: LeakageScore) -> str:
    cw = ", ".join(f"{v:+.2f}" for v in s.cooler_within)
    aw = ", ".join(f"{v:+.2f}" for v in s.accumulator_within)
    return (f"{name:34s} {s.spearman:6.3f} {s.ceiling:6.3f} {100 * s.fraction:6.1f} "
            f"{s.auroc_01:6.3f} {s.auroc_12:6.3f}  cooler [{cw}]  acc [{aw}]")


def _class_row(name: str, s: ClassScore) -> str:
    auc = " ".join(f"{k}:{v:.3f}" for k, v in s.auroc.items())
    conf = "  ".join(f"{k} [{', '.join(f'{x:+.2f}' for x in v)}]" for k, v in s.within.items())
    return (f"{name:30s} n={s.n:4d} ρ={s.spearman:+.3f} ceil={s.ceiling:.3f} "
            f"({100 * s.fraction:5.1f} %)  AUROC {auc}\n{'':32s}within-class ρ: {conf}")


def _within_segment_exponent(est: Arr, mu: Arr, cps: list[int]) -> tuple[float, float, int]:
    """Viscosity exponent b from the slope of log G on log μ inside change-point segments.

    Label-free: segments are the change points of the estimate; a segment counts as leaking
    when its median estimate lies above the campaign median by 3 robust spreads.  Returns
    (b, spread of log μ inside the segments [-], cycles used).
    """
    edges = [0, *cps, est.size]
    med = float(np.median(est))
    mad = float(np.median(np.abs(est - med)))
    xs, ys = [], []
    for a, b in itertools.pairwise(edges):
        g = est[a:b]
        if b - a >= 10 and np.all(g > 0) and float(np.median(g)) > med + 3.0 * mad:
            lm = np.log(mu[a:b])
            xs.append(lm - lm.mean())
            ys.append(np.log(g) - np.log(g).mean())
    if not xs:
        return math.nan, math.nan, 0
    x, y = np.concatenate(xs), np.concatenate(ys)
    return float(np.sum(x * y) / np.sum(x * x)), float(x.std()), int(x.size)


def _shunt(records: list[SeriesRecord], points: list, mu: Arr, labels: ZemaLabels,
           full: npt.NDArray[np.bool_]) -> dict[str, object]:
    """The orifice + laminar-shunt leak size (:mod:`diagnostics.real.shunt`), scored."""
    old = shunt_estimates(records, points, mu, fit_on=full)
    so = score_leakage(old.size, labels.leakage, labels.cooler, labels.accumulator)
    # every cycle's plateaus up to its first departure to the relief valve: the cycles that
    # left the load program are compared on the plateau they share with every cycle and
    # scored, not flagged; λ is fitted where all five plateaus are alike (on the program)
    def mu_of(th: Arr) -> Arr:
        return np.asarray(dynamic_viscosity(Fluid(), th), dtype=np.float64)

    tau, tau_rho = fit_relaxation(records, mu_of, fit_on=full)
    plain = [cycle_point(r, stop_at_relief=True) for r in records]
    sp = shunt_estimates(records, plain, mu_of(np.array([c.theta for c in plain])), fit_on=full)
    reached = [cycle_point(r, stop_at_relief=True, relaxation=tau) for r in records]
    mu_r = mu_of(np.array([c.theta for c in reached]))
    est = shunt_estimates(records, reached, mu_r, fit_on=full)
    off = ~full

    def scores(x: Arr) -> tuple[LeakageScore, LeakageScore, LeakageScore]:
        return tuple(score_leakage(x[m], labels.leakage[m], labels.cooler[m],  # type: ignore[return-value]
                                   labels.accumulator[m])
                     for m in (np.ones_like(full), full, off))

    sc, pr, po = scores(est.size)
    alt = shunt_estimates(records, reached, mu_r)
    sa, pa, _ = scores(alt.size)
    s0, p0, _ = scores(sp.size)
    print()
    print("leak size K = (q_ref(θ,p) − q − λ·Δp/μ·[leaking])/√Δp: orifice + laminar shunt "
          "(paper 000 eq. 6 form); no label used")
    print(f"  label-free nuisance values: leak threshold {est.threshold * 6e4:.3f} l/min "
          f"({int(est.leaking.sum())} cycles leaking), healthy dq/dp "
          f"{est.slope * 6e4 * 1e5:+.4f} l/min/bar, shunt λ = {est.shunt:.3e} m³ "
          f"(fitted on the leaking cycles that ran the whole load program)")
    print("  plateaus: up to the cycle's first departure to the relief valve (cycles that left "
          f"the load program keep their first working plateau: {int(off.sum())} cycles, scored)")
    print(f"  plateau flow: settled value after the accumulator gas's relaxation, τ = {tau:.1f} s "
          "(label-free: the τ where K from the first plateau alone minus K from all plateaus "
          "carries the least rank correlation with θ; |ρ| on the grid 0-8 s: "
          + " ".join(f"{x:.2f}" for x in tau_rho) + ")")
    print(_row("K (all cycles)", sc))
    print(_row("K (cycles on the load program)", pr))
    print(_row("K (cycles that left the program)", po))
    print(_row("  K, plateau means (τ = 0), all", s0))
    print(_row("  K, plateau means (τ = 0), on program", p0))
    print(f"  λ fitted on every leaking cycle instead: λ = {alt.shunt:.3e} m³")
    print(_row("  K, λ on all (all cycles)", sa))
    print(_row("  K, λ on all (on the program)", pa))
    print(_row("before: all plateaus of every cycle", so))
    print("  no one λ leaves both populations free of the cooler: the cycles that left the "
          "program are the hottest, and their first plateau reads less leak than the trend of "
          "the on-program cycles' pooled plateaus")
    med = {}
    for c in (3.0, 20.0, 100.0):
        m = full & (labels.stable == 0) & (labels.cooler == c)
        vals = [float(np.median(est.size[m & (labels.leakage == k)])) for k in (0.0, 1.0, 2.0)]
        med[f"{c:g}"] = vals
        print(f"  cooler {c:5.0f} %: median K [1e-9 m³/(s·Pa^½)] by leakage class "
              + "  ".join(f"{v * 1e9:7.4f}" for v in vals))

    def fig(x: LeakageScore) -> dict[str, object]:
        return {"spearman": x.spearman, "fraction_of_ceiling": x.fraction,
                "auroc_0_1": x.auroc_01, "auroc_1_2": x.auroc_12,
                "cooler_within": list(x.cooler_within),
                "accumulator_within": list(x.accumulator_within),
                "worst_confound": x.worst_confound}

    return {"all_cycles": fig(sc), "load_program_only": fig(pr), "left_program_only": fig(po),
            "relaxation_s": tau, "relaxation_grid_abs_rho": [float(x) for x in tau_rho],
            "plateau_means": {"all_cycles": fig(s0), "load_program_only": fig(p0)},
            "lambda_on_all_cycles": {"shunt_lambda_m3": alt.shunt, "all_cycles": fig(sa),
                                     "load_program_only": fig(pa)},
            "all_plateaus_of_every_cycle": fig(so), "cycles_left_program": int(off.sum()),
            "threshold_l_min": est.threshold * 6e4, "leaking_cycles": int(est.leaking.sum()),
            "healthy_slope_l_min_bar": est.slope * 6e4 * 1e5, "shunt_lambda_m3": est.shunt,
            "median_K_by_cooler_1e9": {k: [v * 1e9 for v in vs] for k, vs in med.items()},
            "targets": {"fraction_of_ceiling_ge_0.95": sc.fraction >= 0.95,
                        "auroc_ge_0.95": min(sc.auroc_01, sc.auroc_12) >= 0.95,
                        "confound_lt_0.1": sc.worst_confound < 0.1}}


def _leakage(points: list, labels: ZemaLabels, light: bool,
             full: npt.NDArray[np.bool_]) -> dict[str, object]:
    est = leakage_estimates(points)
    theta = np.array([p.theta for p in points])
    p = np.array([p.pressure for p in points])
    q = np.array([p.flow for p in points])
    mu = dynamic_viscosity(Fluid(), theta)
    sc = score_leakage(est, labels.leakage, labels.cooler, labels.accumulator)
    stable = labels.stable == 0
    sc_st = score_leakage(est[stable], labels.leakage[stable], labels.cooler[stable],
                          labels.accumulator[stable])
    base = score_leakage(est * mu, labels.leakage, labels.cooler, labels.accumulator)
    cps = change_points(est, min_size=10 if light else 20)
    step = 4 if light else 1
    switches = list(np.flatnonzero(np.diff(labels.leakage)) + 1)
    tol = max(1, TOLERANCE // step)
    hits = sum(1 for s in switches if any(abs(c - s) <= tol for c in cps))
    false = sum(1 for c in cps if not any(abs(c - s) <= tol for s in switches))
    print("pump leakage estimate: extra leakage conductance G_est = (q_ref(θ) − q)/Δp, "
          "q_ref = 97.5 % envelope of the campaign's plateau flows within ±1 °C; no label used")
    print(f"{'estimate':34s} {'rho':>6s} {'ceil':>6s} {'%ceil':>6s} {'AUC01':>6s} {'AUC12':>6s}"
          "  within-leakage-class rank corr. (class 0, 1, 2)")
    print(_row("G_est (all cycles)", sc))
    print(_row("G_est (stable flag 0 only)", sc_st))
    print(_row("G_est·μ(θ) (eq. 6 Cs-like baseline)", base))
    print(f"change points of G_est: {len(cps)}; leakage-label switches {len(switches)}, "
          f"detected within ±{tol} rows: {hits}; change points not at a switch: {false}")

    # --- the cooler confound: what moves with the cooler, and what was tried ---------------
    qref = q + est * p
    deficit = {}
    print()
    print("cooler confound, the data: median flow deficit q_ref − q [l/min] and plateau "
          "pressure [bar] by cooler and leakage class (stable cycles that ran the whole load program)")
    for c in (3.0, 20.0, 100.0):
        cells = []
        for k in (0.0, 1.0, 2.0):
            m = (labels.cooler == c) & (labels.leakage == k) & stable & full
            dq = float(np.median(qref[m] - q[m])) * 6e4 if m.any() else math.nan
            pk = float(np.median(p[m])) / 1e5 if m.any() else math.nan
            deficit[f"{c:g}/{k:g}"] = {"deficit_l_min": dq, "pressure_bar": pk}
            cells.append(f"{dq:6.3f} l/min @ {pk:6.1f} bar")
        th = float(np.median(theta[labels.cooler == c]))
        two_one = (deficit[f"{c:g}/2"]["deficit_l_min"]
                   - deficit[f"{c:g}/1"]["deficit_l_min"])
        deficit[f"{c:g}/2-1"] = {"deficit_l_min": two_one}
        print(f"  cooler {c:5.0f} %  θ={th:5.1f} °C  " + "   ".join(cells)
              + f"   2−1: {two_one:.3f} l/min")
    print("  (classes 1 and 2 move by the same flow with θ, their difference stays: an additive "
          "shunt, not a viscosity factor on the whole leak)")
    variants: dict[str, dict[str, float]] = {}
    print(f"{'variant (no label used in fitting)':44s} {'rho':>6s} {'%ceil':>6s} {'AUC01':>6s} "
          f"{'AUC12':>6s} {'worst|ρ|':>8s}")

    def add(name: str, x: Arr) -> None:
        s = score_leakage(x, labels.leakage, labels.cooler, labels.accumulator)
        variants[name] = {"spearman": s.spearman, "fraction_of_ceiling": s.fraction,
                          "auroc_0_1": s.auroc_01, "auroc_1_2": s.auroc_12,
                          "worst_confound": s.worst_confound}
        print(f"{name:44s} {s.spearman:6.3f} {100 * s.fraction:6.1f} {s.auroc_01:6.3f} "
              f"{s.auroc_12:6.3f} {s.worst_confound:8.2f}")

    for sensor, pts in _SENSOR_POINTS.items():
        add(f"envelope on {sensor}", leakage_estimates(pts))
    for a in (0.0, 0.5):
        add(f"pressure law Δq/Δp^{a:g}", (qref - q) / p ** a)
    b_fit, spread, used = _within_segment_exponent(est, mu, cps)
    print(f"  within-segment fit of b (G·μ^b, {used} cycles in leaking segments): b = "
          f"{b_fit:+.2f}; spread of log μ inside segments {spread:.4f}: not identifiable")
    if math.isfinite(b_fit):
        add(f"G·μ^b, b = {b_fit:+.2f} fitted in segments", est * mu ** b_fit)
    for b in (0.2, 0.3, 0.5):
        add(f"sensitivity only: G·μ^{b:g}", est * mu ** b)
    return {"score": sc, "stable": sc_st, "baseline": base, "cps": len(cps),
            "switches": len(switches), "hits": hits, "false": false,
            "deficit_by_cooler_and_class": deficit, "variants": variants,
            "within_segment_b": {"b": b_fit, "log_mu_spread": spread, "cycles": used},
            "theta_by_cooler": {f"{c:g}": float(theta[labels.cooler == c].mean())
                                for c in (3.0, 20.0, 100.0)}}


_SENSOR_POINTS: dict[str, list] = {}


def _separation(v: Arr, labels: Arr, a: float, b: float) -> dict[str, float]:
    """How far apart two pre-charge classes lie against their own scatter (scoring only).

    d' = (median_b − median_a)/σ with σ the pooled robust spread (1.4826·MAD) of the two
    classes; ``Φ(d'/√2)`` is the AUROC two normal classes that far apart would give, and
    ``(b/a)^(1/n)`` the ratio of gas volumes the polytropic law expects at equal V0 [-].
    """
    xa, xb = v[(labels == a) & np.isfinite(v)], v[(labels == b) & np.isfinite(v)]
    ma, mb = float(np.median(xa)), float(np.median(xb))
    sa = 1.4826 * float(np.median(np.abs(xa - ma)))
    sb = 1.4826 * float(np.median(np.abs(xb - mb)))
    sig = math.sqrt(0.5 * (sa * sa + sb * sb))
    d = (mb - ma) / sig
    return {"measured_ratio": mb / ma, "expected_ratio": (b / a) ** (1.0 / 1.4),
            "relative_spread": sig / ma, "d_prime": d,
            "gaussian_auroc": 0.5 * math.erfc(-d / 2.0)}


def _accumulator(records: list[SeriesRecord], labels: ZemaLabels,
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
    out.update({"upper_steps": s.as_dict(), "relaxation_s": relaxation,
                "upper_steps_plateau_means": s_plain.as_dict(),
                "upper_steps_no_temperature": s_raw.as_dict(),
                "step_rule": "steps between plateaus in the upper half of the cycle's "
                             "working pressures (fixed before scoring)",
                "step_agreement_spearman": agree.tolist(),
                "per_step": per_step, "median_gas_l": med, "separation": sep,
                "cycles_scored": n_ok})
    return out


def _valve(records: list[SeriesRecord], labels: ZemaLabels) -> dict[str, object]:
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


def zema(light: bool) -> dict[str, object]:
    """Run the ZeMA study, print its tables, return its figures."""
    root = zema_root()
    t0 = time.perf_counter()
    n_all = sum(1 for _ in (root / "profile.txt").open())
    cycles = list(range(1, n_all + 1, 4 if light else 1))
    data, labels = load_1hz(root, cycles, sensors=("PS1", "PS2", "FS1", "EPS1", "TS1", "TS2",
                                                   "TS3", "TS4"))
    t_read = time.perf_counter() - t0
    base = {k: v for k, v in data.sensors.items() if k not in ("TS2", "TS3", "TS4")}
    records = read_records(type(data)(data.cycles, base, data.sample_rate))
    t_import = time.perf_counter() - t0 - t_read
    points = [cycle_point(r) for r in records]
    t_est = time.perf_counter() - t0 - t_read - t_import
    for sensor in ("TS1", "TS2", "TS3", "TS4"):
        swapped = dict(base, TS1=data.sensors[sensor])
        recs = read_records(type(data)(data.cycles, swapped, data.sample_rate))
        _SENSOR_POINTS[sensor] = [cycle_point(r) for r in recs]
    print(f"ZeMA hydraulic rig: {len(points)} cycles{' (light: every 4th)' if light else ''}, "
          f"1 Hz, from {root}")
    full = np.array([len(step_volumes(r)) == 4 for r in records])
    print(f"cycles that ran the whole load program (five working plateaus): {int(full.sum())}")
    lk = _leakage(points, labels, light, full)
    mu = dynamic_viscosity(Fluid(), np.array([p.theta for p in points]))
    shunt = _shunt(records, points, mu, labels, full)
    acc = _accumulator(records, labels, float(shunt["relaxation_s"]))  # type: ignore[arg-type]
    valve = _valve(records, labels)
    sc: LeakageScore = lk["score"]  # type: ignore[assignment]
    st: LeakageScore = lk["stable"]  # type: ignore[assignment]
    bl: LeakageScore = lk["baseline"]  # type: ignore[assignment]
    print(f"time: read {t_read:.2f} s, import {t_import:.2f} s, leakage estimate {t_est:.2f} s "
          f"(estimate/import ratio {t_est / t_import:.2f})")
    return {
        "study": "real_data", "light": light, "cycles": len(points),
        "spearman": sc.spearman, "spearman_ceiling": sc.ceiling,
        "fraction_of_ceiling": sc.fraction, "auroc_0_1": sc.auroc_01,
        "auroc_1_2": sc.auroc_12, "cooler_within": list(sc.cooler_within),
        "accumulator_within": list(sc.accumulator_within),
        "worst_confound": sc.worst_confound,
        "stable_only": {"spearman": st.spearman, "fraction_of_ceiling": st.fraction,
                        "auroc_0_1": st.auroc_01, "auroc_1_2": st.auroc_12,
                        "worst_confound": st.worst_confound},
        "mu_normalised": {"spearman": bl.spearman, "fraction_of_ceiling": bl.fraction,
                          "auroc_0_1": bl.auroc_01, "auroc_1_2": bl.auroc_12,
                          "worst_confound": bl.worst_confound},
        "theta_by_cooler": lk["theta_by_cooler"],
        "change_points": lk["cps"], "leakage_switches": lk["switches"],
        "switches_detected": lk["hits"], "change_points_not_at_switch": lk["false"],
        "cooler_confound": {"deficit_by_cooler_and_class": lk["deficit_by_cooler_and_class"],
                            "variants": lk["variants"],
                            "within_segment_b": lk["within_segment_b"]},
        "shunt_model": shunt, "accumulator": acc, "valve": valve,
        "targets": {"fraction_of_ceiling_ge_0.95": sc.fraction >= 0.95,
                    "auroc_ge_0.95": min(sc.auroc_01, sc.auroc_12) >= 0.95,
                    "confound_lt_0.1": sc.worst_confound < 0.1},
        "time_ratio_estimate_to_import": t_est / t_import,
    }
