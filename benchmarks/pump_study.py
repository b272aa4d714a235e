"""Pump characterisation study (issue 4, papers 000 and 001) on the virtual ISO 4409 bench.

Run: ``python -m benchmarks.pump_study`` (``HYDRODIAG_LIGHT=1`` for fewer seeds).

The last sections (:mod:`benchmarks.pump_field_study`) run the field duty cycle of paper 000
§4-5 on generated field records, with and without the documented model gaps, and the Cs
trend of a simulated campaign.

Everything here is SIMULATED: the pump is the stand-in coefficient map of
:mod:`sim.components.gear_pump_map` (built from the description of paper 000's Figure 3),
the data come from :func:`diagnostics.pump.bench.run_virtual_bench`.  The study checks the
methods on data whose truth is known; it measures nothing about a real pump.

Prints a table per topic and, as its last line, one JSON object with the figures.
"""

from __future__ import annotations

import json
import math
import os
import time
from typing import Any

import numpy as np
from numpy.polynomial import polynomial as npoly

from benchmarks.pump_field_study import study_campaign, study_duty_cycle, study_duty_timing
from diagnostics.pump import (
    FLOW_TERMS,
    TORQUE_TERMS,
    BenchData,
    InstrumentNoise,
    best_subset,
    context_from_bench,
    default_levels,
    derived_capacity_intercept,
    derived_capacity_toet,
    derived_capacity_vimax,
    design_columns,
    expected_signs,
    fit_ols,
    iso4409_grid,
    latin_hypercube_plan,
    orthogonal_plan,
    parameterise,
    psr_saturation,
    run_virtual_bench,
    volumetric_efficiency,
)
from sim.components.gear_pump import GearPump
from sim.components.gear_pump_map import (
    MAP_OMEGA_RANGE,
    MAP_P_RANGE,
    MAP_TEMPERATURES,
    stand_in_pump,
)

RPM = 2.0 * math.pi / 60.0
LPM = 6.0e4                      # m³/s -> L/min
CM3_REV = 2.0 * math.pi * 1e6    # m³/rad -> cm³/rev
Z_TOL = 4.0                      # recovery tolerance in standard errors
COEFS = ("Cs", "Cst", "Cv", "Cf")


def _light() -> bool:
    return os.environ.get("HYDRODIAG_LIGHT", "").strip() not in ("", "0", "false", "no")


def _check_grid(n: int = 12) -> tuple[np.ndarray, np.ndarray]:
    P, W = np.meshgrid(np.linspace(*MAP_P_RANGE, n), np.linspace(*MAP_OMEGA_RANGE, n))
    return P.ravel(), W.ravel()


def _bench(pump: GearPump, seed: int, replicates: int = 3) -> BenchData:
    dp, w = iso4409_grid(*default_levels())
    return run_virtual_bench(pump, dp, w, MAP_TEMPERATURES, replicates=replicates, seed=seed)


def _section(title: str) -> None:
    print(f"\n== {title} ==")


def study_map(pump: GearPump) -> dict[str, Any]:
    _section("Stand-in map of the 14.7 cm³/rev gear pump (paper 000 Fig. 3 description; "
             "NOT bench data)")
    P, W = _check_grid(40)
    out: dict[str, Any] = {}
    for th in MAP_TEMPERATURES:
        ev = volumetric_efficiency_model(pump, P, W, th, pump.D)
        em = P * pump.D / pump.torque(P, W, th)
        out[f"{th:g}C"] = {"eta_v_min": float(ev.min()), "eta_v_max": float(ev.max()),
                           "eta_hm_min": float(em.min()), "eta_hm_max": float(em.max())}
        print(f"  {th:4.0f} °C  ηv {ev.min():.4f}..{ev.max():.4f}   ηhm {em.min():.3f}.."
              f"{em.max():.3f}   (20-250 bar, 600-2400 rpm)")
    cs_neg = float(pump.Cs(20e5, 2400 * RPM))
    print(f"  Cs(20 bar, 2400 rpm) = {cs_neg:.2e} (negative: Couette drag > Poiseuille slip)")
    out["Cs_20bar_2400rpm"] = cs_neg
    return out


def volumetric_efficiency_model(pump: GearPump, P: np.ndarray, W: np.ndarray, theta: float,
                                D: float) -> np.ndarray:
    """ηv of the pump model (no noise) with an assumed capacity ``D`` [m³/rad]."""
    return np.asarray(pump.flow(P, W, theta) / (D * W))


def study_capacity(pump: GearPump, bench: BenchData, seeds: int) -> dict[str, Any]:
    _section("Derived capacity (ISO 4409 grid 8 p x 7 n x {22, 60} °C x 3 replicates, "
             "SIMULATED; estimate at the coldest oil)")
    P, W = _check_grid(40)
    print(f"  {'method':<18}{'D [cm³/rev]':>12}{'error [%]':>11}{'SE [%]':>8}"
          f"{'ηv>1 pts':>10}{'max ηv model':>14}   per temperature error [%]")
    out: dict[str, Any] = {}
    for est in (derived_capacity_intercept(bench), derived_capacity_toet(bench),
                derived_capacity_vimax(bench)):
        err = (est.D / pump.D - 1.0) * 100
        ev_data = volumetric_efficiency(bench, est.D)
        ev_model = max(float(volumetric_efficiency_model(pump, P, W, th, est.D).max())
                       for th in MAP_TEMPERATURES)
        per = {f"{k:g}": round((v / pump.D - 1) * 100, 3) for k, v in
               est.per_temperature.items()}
        se = est.std / pump.D * 100 if math.isfinite(est.std) else float("nan")
        print(f"  {est.method:<18}{est.per_rev * 1e6:>12.4f}{err:>+11.3f}{se:>8.3f}"
              f"{(ev_data > 1).mean() * 100:>9.1f}%{ev_model:>14.4f}   {per}")
        out[est.method] = {"D_cm3_rev": est.per_rev * 1e6, "error_pct": err, "se_pct": se,
                           "frac_data_eta_v_gt_1": float((ev_data > 1).mean()),
                           "max_model_eta_v": ev_model, "per_temperature_error_pct": per}
    errs = []
    hot = []
    for s in range(seeds):
        b = _bench(pump, 1000 + s, replicates=2)
        e = derived_capacity_toet(b, level="all")
        errs.append(e.per_temperature[min(e.per_temperature)] / pump.D - 1.0)
        hot.append(e.per_temperature[max(e.per_temperature)] / pump.D - 1.0)
    ea = np.asarray(errs) * 100
    ha = np.asarray(hot) * 100
    within = float(np.mean(np.abs(ea) < 0.5))
    print(f"  Toet over {seeds} seeds (2 replicates): 22 °C error {ea.mean():+.3f} ± "
          f"{ea.std():.3f} %, |error| < 0.5 % in {within * 100:.0f} % of seeds; 60 °C error "
          f"{ha.mean():+.3f} ± {ha.std():.3f} % (speed-dependent slip biases Toet)")
    out["toet_seeds"] = {"n": seeds, "mean_error_pct": float(ea.mean()),
                         "sd_error_pct": float(ea.std()), "frac_within_0p5pct": within,
                         "hot_mean_error_pct": float(ha.mean())}
    return out


def _z_stats(pump: GearPump, fits: dict[str, Any]) -> dict[str, dict[str, float]]:
    P, W = _check_grid(12)
    res: dict[str, dict[str, float]] = {}
    for k in COEFS:
        f = fits[k]
        true = getattr(pump, k)(P, W)
        fit = f.surface(P, W)
        sd = f.std_at(P, W)
        z = (fit - true) / sd
        res[k] = {"max_abs_z": float(np.abs(z).max()),
                  "median_rel_err": float(np.median(np.abs(fit - true) / np.abs(true))),
                  "median_rel_se": float(np.median(sd / np.abs(true))),
                  "chi2_red": f.chi2_red, "residual_rms": f.residual_rms, "r2": f.r2}
    return res


def study_coefficients(pump: GearPump, bench: BenchData, seeds: int) -> dict[str, Any]:
    _section("Loss coefficients, paper 000 eqs. 7-9 and 17-19, cubic surfaces in p and n "
             f"(tolerance: |fit − true| < {Z_TOL:g} SE on a 12 x 12 grid)")
    out: dict[str, Any] = {}
    for label, D in (("D known", pump.D), ("D by Toet", None)):
        r = parameterise(bench, D=D)
        zs = _z_stats(pump, r.fits)
        print(f"  -- {label} (D = {r.D * CM3_REV:.4f} cm³/rev ± {r.D_std * CM3_REV:.4f})")
        print(f"  {'coef':<5}{'true@100bar,1500rpm':>20}{'fit':>11}{'med|err|':>10}"
              f"{'med SE':>8}{'max|z|':>8}{'χ²red':>7}{'resid rms':>11}{'R²':>7}")
        for k in COEFS:
            z = zs[k]
            t0 = float(getattr(pump, k)(1e7, 1500 * RPM))
            f0 = float(r.fits[k].surface(1e7, 1500 * RPM))
            print(f"  {k:<5}{t0:>20.3e}{f0:>11.3e}{z['median_rel_err'] * 100:>9.1f}%"
                  f"{z['median_rel_se'] * 100:>7.1f}%{z['max_abs_z']:>8.2f}{z['chi2_red']:>7.2f}"
                  f"{z['residual_rms']:>11.2e}{z['r2']:>7.3f}")
        out[label.replace(" ", "_")] = zs
    passed = {k: 0 for k in COEFS}
    for s in range(seeds):
        r = parameterise(_bench(pump, 2000 + s, replicates=2), D=pump.D)
        zs = _z_stats(pump, r.fits)
        for k in COEFS:
            passed[k] += zs[k]["max_abs_z"] < Z_TOL
    frac = {k: passed[k] / seeds for k in COEFS}
    print(f"  recovery within {Z_TOL:g} SE over {seeds} seeds (D known, 2 replicates): "
          + ", ".join(f"{k} {v * 100:.0f} %" for k, v in frac.items()))
    out["recovery_fraction"] = frac
    return out


def _model_line(m: Any, unit: str, factor: float) -> str:
    terms = ", ".join(f"{t}={c:.3g}" for t, c in zip(m.terms, m.coef, strict=True))
    return (f"S = {m.S * factor:.4f} {unit}, R² = {m.r2:.6f}, max VIF = {m.max_vif:.1f}, "
            f"AIC = {m.aic:.1f}; b0 = {m.intercept * factor:.3g} {unit}; {terms}")


def study_selection(pump: GearPump, bench: BenchData, seeds: int) -> dict[str, Any]:
    _section("Empirical models, paper 001 Table 1 terms, best subsets (≤ 4 added terms) by "
             "AIC; VIF reported, not filtered")
    ctx = context_from_bench(bench, pump.D)
    out: dict[str, Any] = {}
    for label, lib, forced, y, unit, factor in (
            ("flow", FLOW_TERMS, ("disp",), bench.q, "L/min", LPM),
            ("torque", TORQUE_TERMS, ("coul_wilson",), bench.require_torque(), "N·m", 1.0)):
        cols = design_columns(lib, ctx)
        res: dict[str, Any] = {}
        for check, signs in (("AIC only", None), ("AIC + sign check", expected_signs(lib))):
            sel = best_subset(cols, y, forced=forced, max_terms=4, signs=signs)
            m = sel.best
            ru = sel.runners_up(2.0)
            print(f"  {label}, {check}: {' + '.join(m.terms)}")
            print(f"     {_model_line(m, unit, factor)}")
            print(f"     VIF: {', '.join(f'{t} {v:.1f}' for t, v in m.vif.items())}")
            if ru:
                print("     also within ΔAIC < 2: "
                      + " | ".join(" + ".join(r.terms[len(forced):]) for r in ru))
            res["sign_checked" if signs else "aic_only"] = {
                "terms": list(m.terms), "coef": [float(c) for c in m.coef],
                "intercept": m.intercept * factor, "S": m.S * factor, "unit": unit,
                "r2": m.r2, "max_vif": m.max_vif, "vif": m.vif,
                "runners_up": [list(r.terms) for r in ru]}
        counts: dict[str, int] = {}
        for s in range(seeds):
            b = _bench(pump, 3000 + s, replicates=2)
            c2 = context_from_bench(b, pump.D)
            yy = b.q if label == "flow" else b.require_torque()
            best = best_subset(design_columns(lib, c2), yy, forced=forced, max_terms=4,
                               signs=expected_signs(lib)).best
            for t in best.terms:
                counts[t] = counts.get(t, 0) + 1
        freq = {t.name: counts.get(t.name, 0) / seeds for t in lib if t.name not in forced}
        print(f"     sign-checked selection over {seeds} seeds: "
              + ", ".join(f"{t} {v * 100:.0f} %" for t, v in freq.items()))
        res["selection_frequency"] = freq
        out[label] = res
    return out


def study_plans(pump: GearPump, terms: tuple[str, ...], seeds: int) -> dict[str, Any]:
    n_p, n_w = 6, 5
    n = n_p * n_w
    _section(f"Test plans at equal size: {n} set points (orthogonal {n_p} p x {n_w} n | Latin "
             f"hypercube {n}) x 2 temperatures x 2 replicates, {seeds} seeds; model "
             f"{' + '.join(terms)}")
    P, W = _check_grid(30)
    val = [(P, W, th) for th in MAP_TEMPERATURES]
    val_b = BenchData.concat([run_virtual_bench(pump, P, W, (th,), noise=InstrumentNoise.none(),
                                                with_torque=False) for *_, th in val])
    vcols = design_columns(FLOW_TERMS, context_from_bench(val_b, pump.D))
    out: dict[str, Any] = {}
    for noise_label, noise in (("flow error 1 % of reading", InstrumentNoise()),
                               ("flow error 1 % of 60 L/min full scale",
                                InstrumentNoise(flow_full_scale=1e-3))):
        S: dict[str, list[float]] = {"orthogonal": [], "lhs": []}
        rmse: dict[str, list[float]] = {"orthogonal": [], "lhs": []}
        for s in range(seeds):
            rng = np.random.default_rng(4000 + s)
            plans = {"orthogonal": orthogonal_plan(n_p, n_w, MAP_P_RANGE, MAP_OMEGA_RANGE),
                     "lhs": latin_hypercube_plan(n, MAP_P_RANGE, MAP_OMEGA_RANGE, seed=rng)}
            for name, (dp, w) in plans.items():
                b = run_virtual_bench(pump, dp, w, MAP_TEMPERATURES, replicates=2, noise=noise,
                                      seed=rng, with_torque=False)
                m = fit_ols(design_columns(FLOW_TERMS, context_from_bench(b, pump.D)), b.q,
                            terms)
                S[name].append(m.S * LPM)
                rmse[name].append(float(np.sqrt(np.mean((m.predict(vcols) - val_b.q) ** 2)))
                                  * LPM)
        so, sl = np.asarray(S["orthogonal"]), np.asarray(S["lhs"])
        d = sl - so
        res = {"S_orthogonal": float(so.mean()), "S_lhs": float(sl.mean()),
               "S_diff": float(d.mean()), "S_diff_se": float(d.std(ddof=1) / math.sqrt(seeds)),
               "S_lhs_lower_pct": float((1 - sl.mean() / so.mean()) * 100),
               "frac_seeds_lhs_lower": float(np.mean(d < 0)),
               "val_rmse_orthogonal": float(np.mean(rmse["orthogonal"])),
               "val_rmse_lhs": float(np.mean(rmse["lhs"]))}
        print(f"  {noise_label}:")
        print(f"     S [L/min]   orthogonal {res['S_orthogonal']:.4f}   LHS {res['S_lhs']:.4f}"
              f"   LHS lower by {res['S_lhs_lower_pct']:.1f} % (paired diff "
              f"{res['S_diff']:+.4f} ± {res['S_diff_se']:.4f}; LHS lower in "
              f"{res['frac_seeds_lhs_lower'] * 100:.0f} % of seeds)")
        print(f"     RMSE vs true flow on a 30 x 30 x 2 grid [L/min]   orthogonal "
              f"{res['val_rmse_orthogonal']:.4f}   LHS {res['val_rmse_lhs']:.4f}")
        out["reading" if out == {} else "full_scale"] = res
    return out


def study_psr(pump: GearPump, terms: tuple[str, ...], orders: int) -> dict[str, Any]:
    n = 60
    _section(f"Progressively sequenced regression: LHS {n} set points x 2 temperatures x 2 "
             f"replicates, {orders} random orders")
    rng = np.random.default_rng(5000)
    dp, w = latin_hypercube_plan(n, MAP_P_RANGE, MAP_OMEGA_RANGE, seed=rng)
    b = run_virtual_bench(pump, dp, w, MAP_TEMPERATURES, replicates=2, seed=rng,
                          with_torque=False)
    cols = design_columns(FLOW_TERMS, context_from_bench(b, pump.D))
    summ = psr_saturation(cols, b.q, terms, orders=orders, seed=5001)
    s_med = float(np.median([t.n_sat_S for t in summ.traces]))
    c_med = float(np.median([t.n_sat_coef for t in summ.traces]))
    s_term = float(summ.traces[0].S[-1]) * LPM
    print(f"  saturation size: median {summ.median:.0f} points, 90th percentile "
          f"{summ.p90:.0f} of {summ.n_points} (S within ±10 % of terminal: median {s_med:.0f};"
          f" model within 0.5 S: median {c_med:.0f}); terminal S = {s_term:.4f} L/min")
    return {"n_points": summ.n_points, "median_n_sat": summ.median, "p90_n_sat": summ.p90,
            "median_n_sat_S": s_med, "median_n_sat_coef": c_med, "terminal_S_lpm": s_term}


def study_timing(bench: BenchData, repeats: int) -> dict[str, Any]:
    _section("Timing (same run, same data)")

    def best_of(fn: Any, n: int) -> float:
        times = []
        for _ in range(n):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return min(times)

    V = npoly.polyvander2d(bench.dp / 1e7, bench.omega / 100.0, [3, 3])
    t_base = best_of(lambda: np.linalg.lstsq(V, bench.q, rcond=None), 30 * repeats)
    t_par = best_of(lambda: parameterise(bench), repeats)
    ratio = t_par / t_base
    print(f"  parameterise (Toet + eqs. 7-9, 17-19 + 4 surfaces with SE, best of {repeats}): "
          f"{t_par * 1e3:.2f} ms;"
          f" baseline one lstsq ({V.shape[0]} x {V.shape[1]}, best of {30 * repeats}): "
          f"{t_base * 1e3:.3f} ms; ratio {ratio:.0f}")
    return {"parameterise_ms": t_par * 1e3, "baseline_lstsq_ms": t_base * 1e3, "ratio": ratio,
            "rows": int(V.shape[0])}



def _json_safe(x: Any) -> Any:
    """Plain JSON: numpy scalars to Python numbers, NaN and inf to null."""
    if isinstance(x, dict):
        return {str(k): _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(float(x)) else None
    return x


def main() -> None:
    light = _light()
    n_toet, n_rec, n_sel, n_plan, n_psr, n_rep, n_duty, n_visit = (
        (20, 10, 4, 40, 10, 3, 3, 4) if light else (200, 100, 40, 400, 100, 7, 10, 8))
    t0 = time.perf_counter()
    print("hydrodiag pump study (issue 4): SIMULATED data from the stand-in map; "
          f"{'light' if light else 'full'} run")
    pump = stand_in_pump()
    bench = _bench(pump, seed=42)
    figures: dict[str, Any] = {"light": light, "simulated": True}
    figures["map"] = study_map(pump)
    figures["capacity"] = study_capacity(pump, bench, n_toet)
    figures["coefficients"] = study_coefficients(pump, bench, n_rec)
    figures["selection"] = study_selection(pump, bench, n_sel)
    terms = tuple(figures["selection"]["flow"]["sign_checked"]["terms"])
    figures["plans"] = study_plans(pump, terms, n_plan)
    figures["psr"] = study_psr(pump, terms, n_psr)
    figures["timing"] = study_timing(bench, n_rep)
    figures["duty_cycle"] = study_duty_cycle(pump, n_duty)
    figures["duty_cycle_timing"] = study_duty_timing(pump, 3)
    figures["campaign"] = study_campaign(pump, n_visit)
    figures["wall_s"] = time.perf_counter() - t0
    print(f"\nwall time {figures['wall_s']:.1f} s")
    print(json.dumps(_json_safe(figures), sort_keys=True, allow_nan=False))


if __name__ == "__main__":
    main()
