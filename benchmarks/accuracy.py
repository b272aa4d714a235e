"""Accuracy study of the diagnosis (issue: diagnosis): ``make accuracy``.

Cases: a fault hypothesis drawn uniformly, in two mixes — healthy and the four observable
single faults (cylinder, valve, pump, relief seat); and the same with the three pairs
added; severities log-uniform from
just detectable to severe (clearance ×1.2-2.0, i.e. leakage ×1.7-8; pump leakage ×2-8;
relief seat leak 1-6 × the pump's nominal leakage); load uniform 2.1-6.3 kN; oil
25-60 °C.  The readings come from the *transient* cycle (phase averages), not from the
steady fast path the diagnosis uses, and carry instrument noise drawn uniformly within
each instrument's class bound (flow ±1 %, pressure ±0.25 %, speed ±0.5 %, ratio ±1 %).
Nothing here tunes anything: the diagnosis runs with its defaults.

Three sensor sets: full (pump, chamber pressures, meters B and C, both speeds), no flow
meters (pressures and speeds), velocity ratio alone.  Figures: top-1 accuracy (strict,
and counting the pump/relief-seat pair as one — their signatures are identical with
these sensors, which the diagnosis itself states), truth inside the reported ambiguity
set (95 % credible set), median relative clearance error of correctly ranked cases,
Brier score and a reliability table of the top probability.

Prints tables and, as the last line, a JSON object.  ``HYDRODIAG_LIGHT=1`` runs 40 cases a mix.
"""

from __future__ import annotations

import itertools
import json
import os
import time

import numpy as np

from diagnostics.diagnose import diagnose
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.quantity import DEFAULT_INSTRUMENTS
from diagnostics.signatures import evaluator
from sim.cycle import run_cycle
from sim.errors import HydrodiagError
from sim.rigs import Condition, Rig, reference_rig

TRUTHS = ("healthy", "cylinder", "valve", "pump", "relief_seat", "cylinder+valve",
          "cylinder+pump", "valve+pump")
SETS = {
    "full": ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "speed_work", "speed_return"),
    "no_flow_meters": ("pump_pressure", "p1", "p2", "speed_work", "speed_return"),
    "ratio_alone": ("velocity_ratio",),
}
GROUPS = {"pump": "pump|relief_seat", "relief_seat": "pump|relief_seat"}


def draw_case(rig: Rig, rng: np.random.Generator, truths: tuple[str, ...]
              ) -> tuple[str, dict[str, float], dict[str, float]]:
    """(truth, overrides, true parameter values in reported units)."""
    truth = str(rng.choice(truths))
    ov: dict[str, float] = {}
    params: dict[str, float] = {}
    for comp in truth.split("+"):
        if comp == "cylinder":
            params["cc"] = rig.base["cylinder.cc"] * float(np.exp(rng.uniform(np.log(1.2), np.log(2.0))))
            ov["cylinder.cc"] = params["cc"]
        elif comp == "valve":
            params["cv"] = rig.base["valve.cv"] * float(np.exp(rng.uniform(np.log(1.2), np.log(2.0))))
            ov["valve.cv"] = params["cv"]
        elif comp == "pump":
            params["pump_leak"] = float(np.exp(rng.uniform(np.log(2.0), np.log(8.0))))
            ov["pump.Rlp"] = rig.base["pump.Rlp"] / params["pump_leak"]
        elif comp == "relief_seat":
            params["seat_leak"] = float(np.exp(rng.uniform(np.log(1.0), np.log(6.0))))
            ov["relief.Gseat"] = params["seat_leak"] / rig.base["pump.Rlp"]
    return truth, ov, params


def readings(rig: Rig, ov: dict[str, float], load: float, temp: float) -> dict[str, float] | None:
    res = run_cycle(rig, ov, Condition(load=load, oil_temperature=temp), timeseries=False)
    if not (res.working.completed and res.return_.completed):
        return None
    w, r = res.working, res.return_
    return {"pump_pressure": w["P_pump"], "p1": w["P1"], "p2": w["P2"], "flow_B": w["Q_meter_B"],
            "flow_C": w["Q_meter_C"], "speed_work": w["speed"], "speed_return": r["speed"],
            "velocity_ratio": res.velocity_ratio}


def noisy(values: dict[str, float], fields: tuple[str, ...], rng: np.random.Generator
          ) -> dict[str, float]:
    out = {}
    for f in fields:
        inst = DEFAULT_INSTRUMENTS[f]
        half = inst.relative_bound * abs(values[f]) + inst.absolute_bound
        out[f] = values[f] + rng.uniform(-half, half)
    return out


MIXES = {
    "single_faults": ("healthy", "cylinder", "valve", "pump", "relief_seat"),
    "with_pairs": TRUTHS,
}


def run_mix(rig: Rig, truths: tuple[str, ...], n_cases: int, rng: np.random.Generator
            ) -> tuple[dict[str, dict[str, list[float]]], dict[str, dict[str, int]], int]:
    stats: dict[str, dict[str, list[float]]] = {
        s: {"top1": [], "top1_group": [], "in_set": [], "in_credible": [], "set_size": [],
            "brier": [], "p_top": [], "clearance_err": []} for s in SETS}
    confusion: dict[str, dict[str, int]] = {s: {} for s in SETS}
    skipped = done = 0
    while done < n_cases:
        truth, ov, params = draw_case(rig, rng, truths)
        load, temp = float(rng.uniform(2.1e3, 6.3e3)), float(rng.uniform(25.0, 60.0))
        vals = readings(rig, ov, load, temp)
        if vals is None:
            skipped += 1
            continue
        done += 1
        cond = OperatingCondition.from_readings({"oil_temperature": temp, "load_force": load})
        for sname, fields in SETS.items():
            rec = MeasurementRecord.from_readings("study", cond, noisy(vals, fields, rng))
            try:
                d = diagnose(rig, [rec])
            except HydrodiagError as exc:
                raise SystemExit(f"case {done} ({truth}, {sname}) failed: {exc}") from None
            st = stats[sname]
            top = d.top.name
            st["top1"].append(float(top == truth))
            st["top1_group"].append(float(GROUPS.get(top, top) == GROUPS.get(truth, truth)))
            st["in_set"].append(float(truth in d.isolability.ambiguity_set))
            st["in_credible"].append(float(truth in d.isolability.credible_set))
            st["set_size"].append(float(len(d.isolability.ambiguity_set)))
            probs = {f.name: f.probability for f in d.hypotheses if f.observable}
            st["brier"].append(sum((p - float(h == truth)) ** 2 for h, p in probs.items())
                               + (1.0 if truth not in probs else 0.0))
            st["p_top"].append(d.top.probability)
            key = f"{truth} -> {top}"
            confusion[sname][key] = confusion[sname].get(key, 0) + 1
            if top == truth:
                for p in d.top.parameters:
                    if p.name in ("cc", "cv") and p.name in params:
                        st["clearance_err"].append(abs(p.value / params[p.name] - 1.0))
    return stats, confusion, skipped


def report(mix: str, stats: dict[str, dict[str, list[float]]],
           confusion: dict[str, dict[str, int]]) -> dict[str, object]:
    n = len(next(iter(stats.values()))["top1"])
    print(f"\n== case mix '{mix}' ({', '.join(MIXES[mix])}): {n} cases ==")
    print(f"{'sensor set':16s} {'top-1':>7s} {'top-1*':>7s} {'in amb.':>8s} {'amb size':>8s} "
          f"{'in cred.':>8s} {'Brier':>7s} {'med |Δc|/c':>10s}")
    figures: dict[str, object] = {}
    for sname, st in stats.items():
        err = float(np.median(st["clearance_err"])) if st["clearance_err"] else float("nan")
        fig = {"top1": float(np.mean(st["top1"])), "top1_grouped": float(np.mean(st["top1_group"])),
               "truth_in_ambiguity_set": float(np.mean(st["in_set"])),
               "mean_ambiguity_set_size": float(np.mean(st["set_size"])),
               "truth_in_credible_set": float(np.mean(st["in_credible"])),
               "brier": float(np.mean(st["brier"])), "median_clearance_error": err}
        print(f"{sname:16s} {fig['top1']:7.3f} {fig['top1_grouped']:7.3f} "
              f"{fig['truth_in_ambiguity_set']:8.3f} {fig['mean_ambiguity_set_size']:8.2f} "
              f"{fig['truth_in_credible_set']:8.3f} {fig['brier']:7.3f} {err:10.4f}")
        bins = np.array([0.0, 0.5, 0.7, 0.9, 0.99, 1.0001])
        p, hit = np.array(st["p_top"]), np.array(st["top1"])
        rows = []
        for lo, hi in itertools.pairwise(bins):
            sel = (p >= lo) & (p < hi)
            if sel.any():
                rows.append([float(lo), float(min(hi, 1.0)), int(sel.sum()),
                             round(float(p[sel].mean()), 3), round(float(hit[sel].mean()), 3)])
        fig["reliability"] = rows
        wrong = sorted(((k, v) for k, v in confusion[sname].items()
                        if k.split(" -> ")[0] != k.split(" -> ")[1]), key=lambda kv: -kv[1])[:4]
        fig["top_confusions"] = dict(wrong)
        figures[sname] = fig
    print("reliability of the top probability [bin) n mean-p observed-top-1; top confusions:")
    for sname, fig in figures.items():
        assert isinstance(fig, dict)
        rel = "  ".join(f"[{a:.2f},{b:.2f}) {c} {d:.2f}/{e:.2f}" for a, b, c, d, e in fig["reliability"])
        print(f"  {sname:16s} {rel}")
        print(f"  {'':16s} " + "; ".join(f"{k}: {v}" for k, v in fig["top_confusions"].items()))
    return figures


def main() -> None:
    light = os.environ.get("HYDRODIAG_LIGHT") == "1"
    n_cases = 40 if light else 500
    rig = reference_rig()
    rng = np.random.default_rng(20261121)
    t_start = time.perf_counter()
    print(f"Diagnosis accuracy study: readings from the transient model with instrument noise, "
          f"{n_cases} cases per mix")
    print("top-1* counts pump and relief-seat leakage as one (identical signatures with these "
          "sensors, stated in every such diagnosis); 'in amb.' = truth inside the ambiguity set "
          "(hypotheses the readings cannot reject), 'in cred.' = inside the 95 % credible set")
    results: dict[str, object] = {}
    skipped_total = 0
    for mix, truths in MIXES.items():
        stats, confusion, skipped = run_mix(rig, truths, n_cases, rng)
        skipped_total += skipped
        results[mix] = report(mix, stats, confusion)
    wall = time.perf_counter() - t_start

    # speed: one record, warm (maps of its condition cached) and cold, vs one steady solve
    cond = Condition(load=3.3e3, oil_temperature=41.3)
    vals = readings(rig, {"valve.cv": 50e-6}, cond.load, cond.oil_temperature)
    assert vals is not None
    oc = OperatingCondition.from_readings({"oil_temperature": 41.3, "load_force": 3.3e3})
    rec = MeasurementRecord.from_readings("speed", oc, {k: vals[k] for k in SETS["full"]})
    t0 = time.perf_counter()
    diagnose(rig, [rec])
    t_cold = time.perf_counter() - t0
    reps = 20
    t0 = time.perf_counter()
    for _ in range(reps):
        diagnose(rig, [rec])
    t_warm = (time.perf_counter() - t0) / reps
    ev = evaluator(rig, cond)
    x = np.array([rig.base[n] for n in ev.names])
    t0 = time.perf_counter()
    for _ in range(200):
        ev(x)
    t_eval = (time.perf_counter() - t0) / 200
    print(f"\nSpeed: one record (full set) diagnosed in {1e3 * t_warm:.1f} ms with its condition's "
          f"maps cached, {1e3 * t_cold:.1f} ms cold; one steady-state evaluation "
          f"{1e6 * t_eval:.0f} µs (ratios {t_warm / t_eval:.0f}x and {t_cold / t_eval:.0f}x); "
          f"study wall time {wall:.0f} s, {skipped_total} drawn cases skipped (piston stalled)")
    print(json.dumps({"cases_per_mix": n_cases, "skipped_stalled": skipped_total,
                      "mixes": results,
                      "diagnosis_warm_ms": round(1e3 * t_warm, 3),
                      "diagnosis_cold_ms": round(1e3 * t_cold, 3),
                      "steady_evaluation_us": round(1e6 * t_eval, 2),
                      "warm_over_steady_ratio": round(t_warm / t_eval, 1),
                      "cold_over_steady_ratio": round(t_cold / t_eval, 1),
                      "wall_s": round(wall, 1)}))


if __name__ == "__main__":
    main()
