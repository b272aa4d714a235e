"""Work-precision study of the cycle integrators (issue 17), part of ``make bench``.

For each method and tolerance: the wall time of one full working + return cycle
in-process (best of several, ``run_cycle(..., timeseries=False)`` for the engine's
methods; ``scipy.integrate.solve_ivp`` on the same compiled right-hand side with the same
end-of-stroke events for Radau, BDF and LSODA) against its error in units of sensor noise
σ (velocity 3.2e-4 m/s, pressure 25 kPa, flow 2.33e-6 m³/s): the maximum over the
outputs of each kind of ``|y − y_ref|``, on a 1 kHz grid (RODAS4 and scipy: their dense
output; ROS2, which has none: its own step times), times between the two runs' phase
switches left out.

Reference: RODAS4 at rtol 1e-9; its convergence is shown by RODAS4 at 1e-8 and, as
independent checks, scipy Radau at 1e-9 (whole cycle) and SUNDIALS CVODE (BDF, through
scikit-sundae, rtol 1e-8; working phase to 2 s, before its end-of-stroke event) against it.

Two rigs: the reference rig and the same rig with Stribeck friction (static friction
twice the Coulomb force, Stribeck speed 5 mm/s), a stiff nonlinear element at start-up.
The Stribeck law lives here, not in ``sim/components``: it is a benchmark variant.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.integrate import solve_ivp

from sim.bondgraph import R, call, compile_graph
from sim.bondgraph.laws import law
from sim.cycle import PHASES, integrate_phases, phase_params, run_cycle, sampled_outputs
from sim.rigs import Rig
from sim.rigs.assembly import build_graph
from sim.solver.noise import DEFAULT_NOISE, error_estimate

Arr = npt.NDArray[np.float64]

#: tolerances of each method (full form, light form)
TOLERANCES: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = {
    "RODAS4 (engine)": ((1e-3, 1e-4, 3e-5, 1e-5, 1e-6, 1e-7), (1e-4, 3e-5, 1e-6)),
    "ROS2 (engine)": ((1e-3, 1e-4, 1e-5, 3e-6, 1e-6), (1e-4, 1e-6)),
    "scipy Radau": ((1e-4, 1e-5, 1e-6, 1e-7), (1e-5,)),
    "scipy BDF": ((1e-4, 1e-5, 1e-6, 1e-7), (1e-5,)),
    "scipy LSODA": ((1e-4, 1e-5, 1e-6, 1e-7), (1e-5,)),
}

#: tolerance of the converged reference (1e-10 stalls at the valve switch: the
#: finite-difference Jacobian limits RODAS4 there)
REF_RTOL = 1e-9

#: accuracy target of issue 17 [σ]: velocity 0.3, pressure and flow 0.1
TARGET = {"v": 0.3, "P": 0.1, "Q": 0.1}


@law
def stribeck_force(v: float, Fc: float, Fs: float, v_st: float, Kf: float, v_s: float) -> float:
    """Stribeck friction ``(Fc + (Fs − Fc)·exp(−(v/v_st)²))·tanh(v/v_s) + Kf·v`` [N].

    Armstrong-Hélouvry, Dupont, Canudas de Wit, "A survey of models, analysis tools and
    compensation methods for the control of machines with friction", Automatica 30
    (1994) 1083-1138, eq. (4) (static + Coulomb + viscous with the Stribeck curve), the
    sign smoothed by ``tanh(v/v_s)``.
    """
    return (Fc + (Fs - Fc) * math.exp(-(v / v_st) ** 2)) * math.tanh(v / v_s) + Kf * v


def stribeck_rig(base: Rig) -> Rig:
    """``base`` with its piston friction replaced by :func:`stribeck_force`.

    Static friction ``cylinder.Fs`` = 2× the Coulomb force ``cylinder.Fu`` [N], Stribeck
    speed ``cylinder.v_st`` = 5 mm/s; the sign is smoothed over the rig's ``v_s``.
    """
    graph, _ = build_graph(base.circuit.name)
    graph.parameter("cylinder.Fs", 2.0 * base.base["cylinder.Fu"], "N",
                    "benchmark: static friction, twice the Coulomb force")
    graph.parameter("cylinder.v_st", 5e-3, "m/s", "benchmark: Stribeck speed")
    p = "p:cylinder."
    graph.elements["cylinder.friction"] = R(
        "cylinder.friction", effort=call(stribeck_force, "f", p + "Fu", p + "Fs", p + "v_st",
                                         p + "Kf", p + "v_s"),
        description="Stribeck friction (benchmark variant)")
    return dataclasses.replace(base, model=compile_graph(graph))


def _kinds(rig: Rig) -> dict[str, list[int]]:
    units = rig.model.output_units
    return {"v": [i for i, n in enumerate(rig.model.output_names) if n == "v"],
            "P": [i for i, u in enumerate(units) if u == "Pa"],
            "Q": [i for i, u in enumerate(units) if u == "m^3/s"]}


def _errors(rig: Rig, run: list[tuple[Arr, Arr]], ref: list[tuple[Arr, Arr]]) -> dict[str, float]:
    names = rig.model.output_names
    targets = {n: (DEFAULT_NOISE[u], 1.0) for n, u in zip(names, rig.model.output_units,
                                                          strict=True) if u in DEFAULT_NOISE}
    est = error_estimate(run, ref, 2.0, names, targets)
    out = {}
    for kind, idx in _kinds(rig).items():
        out[kind] = max(est[names[i]] for i in idx)
    return out


def _grid(rig: Rig, params: list[Arr]) -> Arr:
    """The 1 kHz comparison grid over both phases' longest span [s]."""
    span = sum(20.0 * rig.base["cylinder.stroke"] * min(p[rig.model.param_index("cylinder.A1")],
                                                        p[rig.model.param_index("cylinder.A2")])
               / (p[rig.model.param_index("pump.speed")] * p[rig.model.param_index("pump.Vp")])
               for p in params)
    return np.arange(0.0, span, 1e-3)


def _reference(rig: Rig, rtol: float, times: list[Arr] | None = None) -> list[tuple[Arr, Arr]]:
    params = [phase_params(rig, ph, None, rig.default_condition()) for ph in PHASES]
    runs = integrate_phases(rig, params, method="rodas4", rtol=rtol,
                            grid=None if times is not None else _grid(rig, params), times=times)
    return sampled_outputs(runs, rig)


def _scipy_cycle(rig: Rig, method: str, rtol: float) -> list[tuple[Arr, Arr]]:
    m = rig.model
    cond = rig.default_condition()
    stroke = rig.base["cylinder.stroke"]
    ix = m.state_index("cylinder.x")
    grid = np.arange(0.0, 60.0, 1e-3)
    y: Arr | None = None
    t0 = 0.0
    out: list[tuple[Arr, Arr]] = []
    for phase in PHASES:
        p = phase_params(rig, phase, None, cond)
        if y is None:
            y = m.initial_state(p)
        level = stroke if phase == "working" else 0.0
        rhs = m.module.rhs

        def f(t: float, yy: Arr, p: Arr = p, rhs: Any = rhs) -> Arr:
            dy = np.empty_like(yy)
            rhs(t, yy, p, dy)
            return dy

        def ev(t: float, yy: Arr, level: float = level) -> float:
            return float(yy[ix] - level)

        ev.terminal = True  # type: ignore[attr-defined]
        ev.direction = 1.0 if phase == "working" else -1.0  # type: ignore[attr-defined]
        sol = solve_ivp(f, (t0, t0 + 60.0), y, method=method, events=ev, rtol=rtol,
                        atol=rtol * m.scale, dense_output=True)
        if sol.status != 1:
            raise RuntimeError(f"{method} {phase}: {sol.message}")
        t_end = float(sol.t_events[0][0])
        tg = grid[(grid >= t0) & (grid <= t_end)]
        yg = sol.sol(tg).T
        out.append((tg, m.outputs(tg, np.ascontiguousarray(yg), p)))
        y = sol.y_events[0][0].copy()
        t0 = t_end
    return out


def _cvode_check(rig: Rig) -> dict[str, float]:
    """SUNDIALS CVODE (BDF, rtol 1e-8) against RODAS4 at 1e-9, working phase to 2.0 s [σ]."""
    from sksundae.cvode import CVODE

    m = rig.model
    p = phase_params(rig, "working", None, rig.default_condition())
    y0 = m.initial_state(p)
    grid = np.arange(0.0, 2.0 + 1e-12, 1e-3)

    def f(t: float, y: Arr, yp: Arr) -> None:
        m.module.rhs(t, y, p, yp)

    sol = CVODE(f, method="BDF", rtol=1e-8, atol=1e-8 * m.scale).solve(grid, y0)
    if not sol.success:
        raise RuntimeError(f"CVODE: {sol.message}")
    ours = m.integrate(y0, p, 2.0, rtol=REF_RTOL, method="rodas4", times=grid)
    return _errors(rig, [(grid, m.outputs(grid, np.ascontiguousarray(sol.y), p))],
                   [(ours.t, m.outputs(ours.t, ours.y, p))])


def _best_of(fn: Callable[[], Any], repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def study(rig: Rig, light: bool) -> dict[str, Any]:
    """Work-precision rows of ``rig`` and the reference's convergence."""
    ref = _reference(rig, REF_RTOL)
    conv = {"RODAS4 1e-8": _errors(rig, _reference(rig, 1e-8), ref),
            "scipy Radau 1e-9": _errors(rig, _scipy_cycle(rig, "Radau", 1e-9), ref),
            "SUNDIALS CVODE BDF 1e-8 (working phase to 2 s)": _cvode_check(rig)}
    params = [phase_params(rig, ph, None, rig.default_condition()) for ph in PHASES]
    rows: list[dict[str, Any]] = []
    reps = 2 if light else 5
    for method, (full, lite) in TOLERANCES.items():
        for rtol in (lite if light else full):
            if method == "RODAS4 (engine)":
                runs = integrate_phases(rig, params, method="rodas4", rtol=rtol,
                                        grid=_grid(rig, params))
                err = _errors(rig, sampled_outputs(runs, rig), ref)
                fn: Callable[[], Any] = lambda r=rtol: run_cycle(  # noqa: E731
                    rig, rtol=r, method="rodas4", timeseries=False)
                steps = sum(x.res.steps for x in runs)
            elif method == "ROS2 (engine)":
                runs = integrate_phases(rig, params, method="ros2", rtol=rtol)
                ref_at = _reference(rig, REF_RTOL, times=[x.res.t for x in runs])
                err = _errors(rig, sampled_outputs(runs, rig), ref_at)
                fn = lambda r=rtol: run_cycle(rig, rtol=r, method="ros2",  # noqa: E731
                                              timeseries=False)
                steps = sum(x.res.steps for x in runs)
            else:
                name = method.split()[1]
                err = _errors(rig, _scipy_cycle(rig, name, rtol), ref)
                fn = lambda r=rtol, n=name: _scipy_cycle(rig, n, r)  # noqa: E731
                steps = -1
            first = _best_of(fn, 1)
            t = min(first, _best_of(fn, reps)) if "engine" in method and first < 0.3 else first
            ok = all(err[k] <= TARGET[k] for k in TARGET)
            rows.append({"method": method, "rtol": rtol, "time_s": t, "steps": steps,
                         "err_sigma": err, "meets_target": ok})
    return {"rows": rows, "convergence": conv}


def fastest(rows: list[dict[str, Any]], method: str) -> dict[str, Any] | None:
    """Fastest row of ``method`` that meets :data:`TARGET`."""
    ok = [r for r in rows if r["method"] == method and r["meets_target"]]
    return min(ok, key=lambda r: r["time_s"]) if ok else None


def print_table(title: str, res: dict[str, Any]) -> None:
    """Readable table of one rig's study."""
    print(f"\n{title}: error vs a RODAS4 run at rtol 1e-9, in σ (target v ≤ 0.3, P, Q ≤ 0.1)")
    for name, e in res["convergence"].items():
        print(f"  reference check, {name}: v {e['v']:.2e}σ  P {e['P']:.2e}σ  Q {e['Q']:.2e}σ")
    print(f"{'method':18s} {'rtol':>7s} {'time [ms]':>10s} {'steps':>7s} {'v [σ]':>9s} "
          f"{'P [σ]':>9s} {'Q [σ]':>9s}  target")
    for r in res["rows"]:
        e = r["err_sigma"]
        print(f"{r['method']:18s} {r['rtol']:7.0e} {1e3 * r['time_s']:10.2f} {r['steps']:7d} "
              f"{e['v']:9.3g} {e['P']:9.3g} {e['Q']:9.3g}  {'yes' if r['meets_target'] else 'no'}")
