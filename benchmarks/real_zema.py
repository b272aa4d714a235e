"""The ZeMA part of the real-data study (issue 12): leakage, cooler confound, accumulator, valve.

Every estimate is computed from the measured cycles without any label; the labels of
``profile.txt`` only score (:mod:`diagnostics.real.scoring`).  Run through
``make real-data`` (:mod:`benchmarks.real_data`), which prints these tables and the pump
map's, and as its last line one JSON object with every figure.

1. Pump leakage (:mod:`diagnostics.real.leakage`), its score and change points.
   The JSON's top-level figures (``spearman`` … ``worst_confound``, ``targets``) are those
   of the headline estimator, the per-plateau leak size with the plateau profile
   (:mod:`diagnostics.real.profile`) and the accumulator's intake given back to each
   plateau's flow (:mod:`benchmarks.real_zema_confound`, ``shunt_model.accumulator_intake``;
   without it: ``shunt_model.plateau_profile``); the first envelope
   estimate is kept as a labelled comparison under ``envelope_estimate``.
2. The cooler confound: the orifice + laminar-shunt leak size (:mod:`diagnostics.real.shunt`)
   from each cycle's plateaus up to its first departure to the relief valve
   (``cycle_point(stop_at_relief=True)``: the 240 cycles that left the load program are
   compared on the first working plateau they share with every cycle, and corrected rather
   than flagged; their later plateaus follow a relief episode), and what else was tried,
   each *without* labels (labels only score): the
   temperature sensor of the envelope (TS1-TS4), the pressure law of the leak (G = Δq/Δp^a,
   a = 0, ½, 1), a viscosity exponent b (G·μ^b) fitted label-free inside change-point
   segments, and, as a sensitivity table only (never used to choose), G·μ^b on a grid.
   Then the service's answer (``POST /rigs/{rig_id}/pump-leak``, ``hydrodiag pump-leak``:
   :mod:`diagnostics.real.monitor` with its defaults), scored with its steps against the
   label's switches (:mod:`benchmarks.real_zema_monitor`, JSON ``service_estimate``).
3. Accumulator gas volume from the oil stored at the load steps, the steps chosen by a
   rule fixed before scoring (:mod:`benchmarks.real_zema_program`).
4. Valve switching time from the pressure step at the valve's switching, on all cycles at
   1 Hz, and checked on the raw 100 Hz cycles of ``fullres_samples/``
   (:mod:`benchmarks.real_zema_program`).
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
import numpy.typing as npt

from benchmarks.real_zema_confound import accumulator_corrected
from benchmarks.real_zema_monitor import service_estimate
from benchmarks.real_zema_program import accumulator, valve_lag
from diagnostics.real.accumulator import step_volumes
from diagnostics.real.leakage import (
    LeakageScore,
    change_points,
    cycle_point,
    leakage_estimates,
    score_leakage,
)
from diagnostics.real.profile import plateau_deficits, plateau_table, profile_sizes
from diagnostics.real.shunt import fit_relaxation, shunt_estimates
from diagnostics.real.zema import (
    ZemaLabels,
    load_1hz,
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
    # the headline: every plateau against the healthy flow of the same plateau, the cycles
    # measured on their first plateaus alone referred to the whole program by the profile
    table = plateau_table(records, relaxation=tau)
    dk = plateau_deficits(table, ~est.leaking, est.slope)
    prof = profile_sizes(dk, table.pressure, mu_of(table.theta), table.theta, est.leaking, full)
    kc, kp, ko = scores(prof.size)
    print()
    print("leak size per plateau K_k = (Δq_k − λ·Δp_k/μ·[leaking])/√Δp_k, Δq_k against the "
          "healthy flow of the same plateau; cycle size = mean of K_k/r_k (no label used)")
    print("  plateau profile r_k (median K_k/mean K of the leaking cycles on the program): "
          + " ".join(f"{x:.3f}" for x in prof.profile) + f"; λ = {prof.shunt:.3e} m³")
    print(_row("K profile (all cycles)", kc))
    print(_row("K profile (on the load program)", kp))
    print(_row("K profile (left the program)", ko))
    ka, acc_fig = accumulator_corrected(records, labels, est.leaking, est.slope, tau, full,
                                        mu_of, _row)
    med = {}
    for c in (3.0, 20.0, 100.0):
        m = full & (labels.stable == 0) & (labels.cooler == c)
        vals = [float(np.median(est.size[m & (labels.leakage == k)])) for k in (0.0, 1.0, 2.0)]
        med[f"{c:g}"] = vals
        print(f"  cooler {c:5.0f} %: median K [1e-9 m³/(s·Pa^½)] by leakage class "
              + "  ".join(f"{v * 1e9:7.4f}" for v in vals))

    return {"accumulator_intake": acc_fig,
            "plateau_profile": {"all_cycles": kc.figures(), "load_program_only": kp.figures(),
                                "left_program_only": ko.figures(), "shunt_lambda_m3": prof.shunt,
                                "profile": [float(x) for x in prof.profile]},
            "headline": ka,
            "all_cycles": sc.figures(), "load_program_only": pr.figures(), "left_program_only": po.figures(),
            "relaxation_s": tau, "relaxation_grid_abs_rho": [float(x) for x in tau_rho],
            "plateau_means": {"all_cycles": s0.figures(), "load_program_only": p0.figures()},
            "lambda_on_all_cycles": {"shunt_lambda_m3": alt.shunt, "all_cycles": sa.figures(),
                                     "load_program_only": pa.figures()},
            "all_plateaus_of_every_cycle": so.figures(), "cycles_left_program": int(off.sum()),
            "threshold_l_min": est.threshold * 6e4, "leaking_cycles": int(est.leaking.sum()),
            "healthy_slope_l_min_bar": est.slope * 6e4 * 1e5, "shunt_lambda_m3": est.shunt,
            "median_K_by_cooler_1e9": {k: [v * 1e9 for v in vs] for k, vs in med.items()},
            "targets": _targets(ka)}


def _targets(s: LeakageScore) -> dict[str, bool]:
    return {"fraction_of_ceiling_ge_0.95": s.fraction >= 0.95,
            "auroc_ge_0.95": min(s.auroc_01, s.auroc_12) >= 0.95,
            "confound_lt_0.1": s.worst_confound < 0.1}


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
    print(_row("G_est (all cycles) [envelope]", sc))
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
    service = service_estimate(records, labels, light)
    acc = accumulator(records, labels, float(shunt["relaxation_s"]))  # type: ignore[arg-type]
    valve = valve_lag(records, labels)
    sc: LeakageScore = lk["score"]  # type: ignore[assignment]
    st: LeakageScore = lk["stable"]  # type: ignore[assignment]
    bl: LeakageScore = lk["baseline"]  # type: ignore[assignment]
    print(f"time: read {t_read:.2f} s, import {t_import:.2f} s, leakage estimate {t_est:.2f} s "
          f"(estimate/import ratio {t_est / t_import:.2f})")
    hd: LeakageScore = shunt.pop("headline")  # type: ignore[assignment]
    return {
        "study": "real_data", "light": light, "cycles": len(points),
        "estimator": "leak size per plateau against the same plateau's healthy flow, "
                     "orifice + laminar shunt, plateau profile, the accumulator's intake "
                     "given back to each plateau's flow (shunt_model.accumulator_intake)",
        "spearman": hd.spearman, "spearman_ceiling": hd.ceiling,
        "fraction_of_ceiling": hd.fraction, "auroc_0_1": hd.auroc_01,
        "auroc_1_2": hd.auroc_12, "cooler_within": list(hd.cooler_within),
        "accumulator_within": list(hd.accumulator_within),
        "worst_confound": hd.worst_confound,
        "envelope_estimate": {"spearman": sc.spearman, "fraction_of_ceiling": sc.fraction,
                              "auroc_0_1": sc.auroc_01, "auroc_1_2": sc.auroc_12,
                              "cooler_within": list(sc.cooler_within),
                              "accumulator_within": list(sc.accumulator_within),
                              "worst_confound": sc.worst_confound,
                              "targets": _targets(sc),
                              "stable_only": {"spearman": st.spearman,
                                              "fraction_of_ceiling": st.fraction,
                                              "auroc_0_1": st.auroc_01, "auroc_1_2": st.auroc_12,
                                              "worst_confound": st.worst_confound},
                              "mu_normalised": {"spearman": bl.spearman,
                                                "fraction_of_ceiling": bl.fraction,
                                                "auroc_0_1": bl.auroc_01,
                                                "auroc_1_2": bl.auroc_12,
                                                "worst_confound": bl.worst_confound}},
        "theta_by_cooler": lk["theta_by_cooler"],
        "change_points": lk["cps"], "leakage_switches": lk["switches"],
        "switches_detected": lk["hits"], "change_points_not_at_switch": lk["false"],
        "cooler_confound": {"deficit_by_cooler_and_class": lk["deficit_by_cooler_and_class"],
                            "variants": lk["variants"],
                            "within_segment_b": lk["within_segment_b"]},
        "shunt_model": shunt, "service_estimate": service, "accumulator": acc, "valve": valve,
        "targets": _targets(hd),
        "time_ratio_estimate_to_import": t_est / t_import,
    }
