"""Field part of the pump study (paper 000 §4-5), run by :mod:`benchmarks.pump_study`.

The field duty cycle (:mod:`sim.duty_cycle`, :mod:`diagnostics.pump.field`) on generated
field records, with and without the documented model gaps (side-plate lag, hysteresis),
its timing, and the Cs trend of a simulated campaign (:mod:`diagnostics.pump.field_slip`).
Everything here is SIMULATED from the stand-in pump map.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from diagnostics.pump.field import predict, residual_tests
from diagnostics.pump.field_record import HiddenEffects, generate_field_record
from diagnostics.pump.field_slip import campaign_trend, visit_slip
from sim.components.gear_pump import CoefficientSurface, GearPump
from sim.duty_cycle import duty_cycle_model

RPM = 2.0 * math.pi / 60.0

EFFECTS = {"none": HiddenEffects(), "side-plate lag": HiddenEffects(side_plate_lag=0.3),
           "hysteresis": HiddenEffects(hysteresis=0.3)}



def _section(title: str) -> None:
    print(f"\n== {title} ==")


def study_duty_cycle(pump: GearPump, seeds: int) -> dict[str, Any]:
    _section(f"Field duty cycle (paper 000 §4-5): generated 60 s records at 1467 rpm, oil 40->43 "
             f"°C, 30 ms, flowmeter ±1 % (rectangular), {seeds} seeds per case; hidden effects: "
             "lag τ = 0.3 s, hysteresis h = 0.3 of the slip")
    print(f"  {'hidden effect':<15}{'model err rms/max [%]':>22}{'resid rms [%]':>14}"
          f"{'in ±1 %':>8}{'LB p med':>9}{'size [%]':>9}{'structured':>11}{'lag named':>10}"
          f"{'hyst named':>11}")
    out: dict[str, Any] = {}
    for name, eff in EFFECTS.items():
        rows: dict[str, list[float]] = {k: [] for k in ("err_rms", "err_max", "rms", "within",
                                                        "lb_p", "size", "structured", "lag",
                                                        "hyst")}
        for s in range(seeds):
            rec = generate_field_record(60.0, effects=eff, seed=6000 + s)
            pred = predict(rec, pump)
            rt = residual_tests(pred, rec)
            err = rec.truth["flow"] / pred.q_model - 1.0
            for k, v in (("err_rms", np.sqrt(np.mean(err**2))), ("err_max", np.abs(err).max()),
                         ("rms", rt.rms), ("within", rt.within_bound), ("lb_p", rt.ljung_box_p),
                         ("size", rt.structure_rms), ("structured", rt.structured),
                         ("lag", "response lag" in rt.named), ("hyst", "hysteresis" in rt.named)):
                rows[k].append(float(v))
        f = {k: float(np.median(v)) if k in ("lb_p", "size") else float(np.mean(v))
             for k, v in rows.items()}
        f["err_max"] = float(np.max(rows["err_max"]))
        print(f"  {name:<15}{f['err_rms'] * 100:>12.3f} / {f['err_max'] * 100:<7.3f}"
              f"{f['rms'] * 100:>14.3f}{f['within'] * 100:>7.1f}%{f['lb_p']:>9.2g}"
              f"{f['size'] * 100:>9.3f}{f['structured'] * 100:>10.0f}%{f['lag'] * 100:>9.0f}%"
              f"{f['hyst'] * 100:>10.0f}%")
        out[name] = f
    print("  (model err: generated truth vs the base model's prediction, no noise; 'in ±1 %': "
          "readings within the flowmeter bound of the prediction; structured: Ljung-Box p < 0.01"
          " and size ≥ 0.1 %)")
    return out


def study_duty_timing(pump: GearPump, repeats: int) -> dict[str, Any]:
    _section("Timing of one 60 s duty cycle (2001 samples at 30 ms; same run, same compiled model)")
    rec = generate_field_record(60.0, seed=7000)
    m = duty_cycle_model()
    predict(rec, pump)
    m.quasi_static(rec.t, rec.pressure, rec.theta, rec.speed, pump)
    t_dyn, t_qs, pred, q_qs = math.inf, math.inf, None, np.empty(0)
    for _ in range(repeats):
        t0 = time.perf_counter()
        pred = predict(rec, pump)
        t1 = time.perf_counter()
        q_qs = m.quasi_static(rec.t, rec.pressure, rec.theta, rec.speed, pump)
        t2 = time.perf_counter()
        t_dyn, t_qs = min(t_dyn, t1 - t0), min(t_qs, t2 - t1)
    assert pred is not None
    d = pred.q_model / q_qs - 1.0
    ratio = t_dyn / t_qs
    print(f"  dynamic (ROS2, rtol 1e-4, input upsampled x2, {pred.run.steps} steps): "
          f"{t_dyn * 1e3:.0f} ms; baseline: the same model's steady state (Newton) at each of "
          f"the {rec.t.size} samples: {t_qs * 1e3:.0f} ms; ratio {ratio:.1f} (best of {repeats})")
    print(f"  dynamic vs quasi-static meter flow: rms {np.sqrt(np.mean(d**2)) * 100:.2f} %, max "
          f"{np.abs(d).max() * 100:.2f} % (oil stored in the hose on pressure ramps)")
    return {"dynamic_ms": t_dyn * 1e3, "baseline_steady_each_sample_ms": t_qs * 1e3,
            "ratio": ratio, "steps": pred.run.steps, "samples": int(rec.t.size),
            "dynamic_vs_quasi_static_rms_pct": float(np.sqrt(np.mean(d**2)) * 100),
            "dynamic_vs_quasi_static_max_pct": float(np.abs(d).max() * 100)}


def study_campaign(pump: GearPump, visits: int) -> dict[str, Any]:
    hours = 2000.0
    _section(f"Cs from field records (eq. 7, cold 25 °C / warm 55 °C duty cycles of 30 s) over a "
             f"campaign: {visits} visits in {hours:.0f} h, Cs worn x1 -> x2 (SIMULATED)")
    levels = {"standby": (20e5, 20e5), "lowering": (90e5, 90e5), "raising": (135e5, 135e5)}
    w = 1467 * RPM
    times, ests, truth, z = [], [], [], []
    for v, k in enumerate(np.linspace(1.0, 2.0, visits)):
        worn = GearPump(Cs=CoefficientSurface(k * pump.Cs.coef), Cst=pump.Cst, Cv=pump.Cv,
                        Cf=pump.Cf, note="stand-in map, Cs worn")
        recs = [generate_field_record(30.0, theta=th, pump=worn, seed=8000 + 2 * v + i,
                                      levels=levels, ripple=0.0)
                for i, th in enumerate(((25.0, 26.0), (55.0, 55.5)))]
        res = [r for r in visit_slip(recs[0], recs[1], pump) if abs(r.level - 135e5) < 5e5]
        if not res:
            continue
        e = res[0].estimate
        c_true = k * float(pump.Cs(res[0].level, w))
        times.append(v * hours * 3600.0 / (visits - 1))
        ests.append(e)
        truth.append(c_true)
        z.append((e.value - c_true) / e.u)
    thr = 2.5 * float(pump.Cs(135e5, w))
    tr = campaign_trend(times, ests, thr)
    fit = tr.forecast.fit
    slope_true = (truth[-1] - truth[0]) / (times[-1] - times[0])
    left_true = (thr - truth[-1]) / slope_true
    rel_u = float(np.median([e.relative for e in ests]))
    print(f"  Cs at 135 bar: median relative u {rel_u * 100:.1f} %, |z| max {np.abs(z).max():.2f} "
          f"({len(ests)} of {visits} visits gave a pair)")
    assert fit is not None
    print(f"  slope {fit.slope * 3.6e3 * 1e3:.3e} /1000 h (95 % {fit.slope_low * 3.6e6:.3e} .. "
          f"{fit.slope_high * 3.6e6:.3e}); true {slope_true * 3.6e6:.3e}")
    print(f"  time to Cs = {thr:.3e}: {tr.forecast.time_left / 3600:.0f} h (95 % "
          f"{tr.forecast.time_left_low / 3600:.0f} .. {tr.forecast.time_left_high / 3600:.0f} h);"
          f" true {left_true / 3600:.0f} h")
    return {"visits": len(ests), "median_rel_u": rel_u, "max_abs_z": float(np.abs(z).max()),
            "slope_per_kh": fit.slope * 3.6e6, "slope_low_per_kh": fit.slope_low * 3.6e6,
            "slope_high_per_kh": fit.slope_high * 3.6e6, "slope_true_per_kh": slope_true * 3.6e6,
            "time_left_h": tr.forecast.time_left / 3600, "time_left_true_h": left_true / 3600,
            "time_left_low_h": tr.forecast.time_left_low / 3600,
            "time_left_high_h": tr.forecast.time_left_high / 3600}
