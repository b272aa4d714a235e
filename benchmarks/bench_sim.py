"""Benchmark of the simulation core (issue: bond-graph core): ``make bench``.

1. One full working + return cycle of the reference rig with the compiled ROS2 solver,
   against a straightforward implementation of the same equations: the generated
   right-hand side as plain Python, integrated by ``scipy.integrate.solve_ivp`` (LSODA)
   with the same end-of-stroke events.  Both are checked against a tight-tolerance run
   (phase speeds within 0.5 %), then timed in this same run; the ratio is the figure.
2. 1,000 steady-state cycle evaluations (both phases' operating points) over random
   piston and spool clearances, loads and temperatures.
3. Work-precision (issue 17, :mod:`benchmarks.work_precision`): RODAS4, ROS2 and scipy's
   Radau, BDF and LSODA against a converged reference, on the reference rig and on a
   Stribeck-friction variant; the time of a noise-accurate cycle (velocity ≤ 0.3σ,
   pressure and flow ≤ 0.1σ) as a ratio to ROS2's at the same accuracy; the default
   noise-accurate run with its error estimate; ``POST /simulate`` sampled at 1 kHz as CSV
   over HTTP (a live server on a temporary store).

Prints a table and, as its last line, a JSON object with the figures.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from benchmarks.work_precision import fastest, print_table, stribeck_rig, study
from sim.cycle import PHASES, phase_params, run_cycle
from sim.rigs import Condition, Rig, reference_rig
from sim.steady import steady_cycle


def _best_of(fn: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def lsoda_cycle(rig: Rig, rtol: float) -> dict[str, float]:
    """The same cycle with solve_ivp/LSODA and a plain-Python right-hand side."""
    m = rig.model
    rhs = m.plain_rhs()
    cond = rig.default_condition()
    stroke = rig.base["cylinder.stroke"]
    ix = m.state_index("cylinder.x")
    atol = rtol * m.scale
    y = None
    t0 = 0.0
    speeds: dict[str, float] = {}
    for phase in PHASES:
        p = phase_params(rig, phase, None, cond)
        if y is None:
            y = m.initial_state(p)
        level = stroke if phase == "working" else 0.0

        def f(t: float, yy: np.ndarray, p: np.ndarray = p) -> np.ndarray:
            dy = np.empty_like(yy)
            rhs(t, yy, p, dy)
            return dy

        def ev(t: float, yy: np.ndarray, level: float = level) -> float:
            return float(yy[ix] - level)

        ev.terminal = True  # type: ignore[attr-defined]
        ev.direction = 1.0 if phase == "working" else -1.0  # type: ignore[attr-defined]
        sol = solve_ivp(f, (t0, t0 + 60.0), y, method="LSODA", events=ev, rtol=rtol, atol=atol)
        if sol.status != 1:
            raise RuntimeError(f"LSODA {phase}: {sol.message}")
        t_end = float(sol.t_events[0][0])
        speeds[phase] = stroke / (t_end - t0)
        speeds[f"{phase}_steps"] = float(sol.t.size)
        y = sol.y_events[0][0].copy()
        t0 = t_end
    return speeds


RTOLS = (3e-2, 1e-2, 1e-3)


def noise_accurate(rig: Rig) -> dict[str, Any]:
    """Best-of-5 time of the default noise-accurate cycle on a 1 kHz grid."""
    t, res = _best_of(lambda: run_cycle(rig, method="rodas4", sample_rate=1000.0), 5)
    rep = res.solver
    shown = ("v", "P_pump", "P1", "Q_meter_B", "Q_meter_C")
    return {"time_ms": 1e3 * t, "rtol": rep.rtol,
            "error_sigma": {k: round(v, 4) for k, v in rep.error_sigma.items() if k in shown}}


def http_simulate(repeats: int = 5) -> dict[str, Any]:
    """``POST /simulate`` (defaults: noise-accurate) sampled at 1 kHz as CSV, over HTTP."""
    import tempfile
    from pathlib import Path

    from tests.app.live import live_server, sqlite_settings

    body = {"rig_id": 1, "timeseries": "csv", "sample_rate": 1000.0}
    with tempfile.TemporaryDirectory() as tmp, \
            live_server(sqlite_settings(Path(tmp))) as live:
        best, size, rows = float("inf"), 0, 0
        for _ in range(repeats + 1):  # the first loads the rig
            t0 = time.perf_counter()
            response = live.client.post("/simulate", json=body, headers=live.auth)
            dt = time.perf_counter() - t0
            if response.status_code != 200:
                raise RuntimeError(f"/simulate answered {response.status_code}: {response.text}")
            best = min(best, dt)
            size = len(response.content)
            rows = sum(1 for line in response.text.splitlines() if line[:1].isdigit())
    return {"time_ms": 1e3 * best, "bytes": size, "rows": rows, "repeats": repeats}


def main() -> None:
    light = os.environ.get("HYDRODIAG_LIGHT") == "1"
    rig = reference_rig()
    run_cycle(rig, method="ros2", timeseries=False)  # compile / load the cache, warm up
    ref = run_cycle(rig, rtol=1e-6, method="ros2", timeseries=False)
    ref_speed = {"working": ref.working["speed"], "return": ref.return_["speed"]}

    def err(w: float, r: float) -> float:
        return max(abs(w / ref_speed["working"] - 1), abs(r / ref_speed["return"] - 1))

    rows = []
    for rtol in RTOLS:
        t, o = _best_of(lambda rtol=rtol: run_cycle(rig, rtol=rtol, method="ros2",
                                                    timeseries=False), 3 if light else 7)
        rows.append(("compiled ROS2", rtol, t, err(o.working["speed"], o.return_["speed"]),
                     o.steps["working"] + o.steps["return"]))
    for rtol in RTOLS:
        t, b = _best_of(lambda rtol=rtol: lsoda_cycle(rig, rtol), 1 if light else 2)
        rows.append(("solve_ivp LSODA, plain-Python RHS", rtol, t, err(b["working"], b["return"]),
                     int(b["working_steps"] + b["return_steps"])))

    def pick(method: str, rtol: float | None = None) -> tuple[str, float, float, float, int]:
        ok = [r for r in rows if r[0] == method and r[3] < 0.005
              and (rtol is None or r[1] == rtol)]
        return min(ok, key=lambda r: r[2])

    ours_same, base_same = pick("compiled ROS2", 1e-3), pick("solve_ivp LSODA, plain-Python RHS",
                                                           1e-3)
    ours_best, base_best = pick("compiled ROS2"), pick("solve_ivp LSODA, plain-Python RHS")

    rng = np.random.default_rng(2026)
    n_steady = 200 if light else 1000
    cases = [({"cylinder.cc": rng.uniform(60e-6, 140e-6), "valve.cv": rng.uniform(25e-6, 70e-6)},
              Condition(load=float(rng.choice([2.1e3, 4.2e3, 6.3e3])),
                        oil_temperature=rng.uniform(30.0, 60.0))) for _ in range(n_steady)]
    steady_cycle(rig, *cases[0])  # warm start and compile
    t0 = time.perf_counter()
    for ov, cond in cases:
        steady_cycle(rig, ov, cond)
    t_steady = time.perf_counter() - t0
    st = steady_cycle(rig)
    err_steady = err(st.working["speed"], st.return_["speed"])

    print("Reference rig, one working + return cycle; speed error against a run at rtol 1e-6")
    print(f"{'method':36s} {'rtol':>7s} {'time [s]':>10s} {'speed error':>12s} {'steps':>7s}")
    for name, rtol, t, e, n in rows:
        print(f"{name:36s} {rtol:7.0e} {t:10.4f} {e:12.2e} {n:7d}")
    same = base_same[2] / ours_same[2]
    best = base_best[2] / ours_best[2]
    print(f"\nspeed-up at the same tolerance (1e-3, the library default): {same:.1f}x "
          "(target >= 30x)")
    print(f"speed-up, each at its fastest tolerance with speeds within 0.5 %: {best:.1f}x")
    print(f"{n_steady} steady-state cycle evaluations (both phases each): {t_steady:.3f} s "
          f"({1e6 * t_steady / n_steady:.0f} µs each); steady speeds vs transient: "
          f"{err_steady:.2e}")
    wp = {"reference": study(rig, light), "stribeck": study(stribeck_rig(rig), light)}
    noise = noise_accurate(rig)
    http = http_simulate()
    figures: dict[str, Any] = {}
    for name, res in wp.items():
        print_table(f"Work-precision, {name} rig", res)
        r4, r2 = fastest(res["rows"], "RODAS4 (engine)"), fastest(res["rows"], "ROS2 (engine)")
        figures[name] = {
            "rodas4_fastest_on_target_ms": None if r4 is None else round(1e3 * r4["time_s"], 3),
            "rodas4_rtol": None if r4 is None else r4["rtol"],
            "ros2_fastest_on_target_ms": None if r2 is None else round(1e3 * r2["time_s"], 3),
            "ros2_rtol": None if r2 is None else r2["rtol"],
            "ros2_over_rodas4": (None if r4 is None or r2 is None
                                 else round(r2["time_s"] / r4["time_s"], 2)),
            "reference_check_sigma": res["convergence"],
        }
        print(f"fastest on target: RODAS4 {figures[name]['rodas4_fastest_on_target_ms']} ms, "
              f"ROS2 {figures[name]['ros2_fastest_on_target_ms']} ms (ratio "
              f"{figures[name]['ros2_over_rodas4']}; None: not on target at the tolerances "
              "tried)")
    print(f"\nnoise-accurate default (rodas4, 1 kHz grid, error estimate included): "
          f"{noise['time_ms']:.2f} ms, rtol {noise['rtol']:.3g}, estimated error "
          + ", ".join(f"{k} {v:.3g}σ" for k, v in noise["error_sigma"].items()))
    print(f"POST /simulate, 1 kHz CSV over HTTP (best of {http['repeats']}): "
          f"{http['time_ms']:.1f} ms, {http['rows']} rows, {http['bytes']} bytes")
    print(json.dumps({
        "work_precision": figures,
        "noise_accurate_cycle_ms": round(noise["time_ms"], 3),
        "noise_accurate_error_sigma": noise["error_sigma"],
        "simulate_http_csv_1khz_ms": round(http["time_ms"], 2),
        "cycle_time_s": round(ours_same[2], 6),
        "lsoda_baseline_time_s": round(base_same[2], 6),
        "speedup_vs_lsoda_same_rtol": round(same, 2),
        "speedup_vs_lsoda_best_within_0p5pct": round(best, 2),
        "cycle_speed_error": float(f"{ours_same[3]:.3e}"),
        "lsoda_speed_error": float(f"{base_same[3]:.3e}"),
        "steady_speed_error": float(f"{err_steady:.3e}"),
        "steady_evaluations": n_steady,
        "steady_total_time_s": round(t_steady, 6),
        "steady_per_evaluation_us": round(1e6 * t_steady / n_steady, 2),
        "working_speed_m_s": round(ref_speed["working"], 6),
        "return_speed_m_s": round(ref_speed["return"], 6),
        "velocity_ratio": round(ref.velocity_ratio, 6),
    }))


if __name__ == "__main__":
    main()
