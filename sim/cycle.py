"""The working + return cycle of a rig (paper 002 §3), transient.

Working phase: spool at N = +1 (P→A, B→T), the load acts, the piston extends from the
chamber-1 end stop until it reaches the stroke.  Return phase: spool at N = −1, no load
(eq. 52), the piston retracts to x = 0, starting from the state the working phase ended
in.  Each phase ends on an event (the piston reaching its end of stroke, as the rig's
terminal switches 24/25 do) or at ``t_max`` if the piston stalls.  With ``hold`` the
working phase is switched by time only, at ``t_max``: a piston that reaches its stop
earlier is held there (a dwell at the end stop, the pump flow going over the relief valve,
paper 002 eq. 6), as a timer-switched test stroke is.

Phase averages: the speed is the least-squares slope of the position over the middle 80 %
of the stroke (what a linear encoder reads; stroke over the phase's ``duration`` counts the
start-up too); pressures and flows are time averages over the same middle 80 %, where the
paper's meters are read (start-up and end-stop transients left out).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from sim.bondgraph.model import IntegrationResult
from sim.cycle_result import SUMMARY_UNITS, CycleResult, PhaseSummary, SolverReport
from sim.errors import ParameterError, SolverLimitError
from sim.numbers import field_number
from sim.phase_reading import settled_window, steady_slope, steady_window, time_average
from sim.rigs.assembly import Condition, Rig, check_overrides, require_rig
from sim.solver.limits import SolverLimits
from sim.solver.noise import NoiseAccuracy, error_estimate

__all__ = ["METHODS", "PHASES", "SUMMARY_UNITS", "CycleResult", "PhaseRun", "PhaseSummary",
           "SolverReport", "integrate_phases", "phase_limit", "phase_params", "phase_settings",
           "run_cycle", "sampled_outputs", "stall_guard", "stroke_of"]

#: integration methods of :func:`run_cycle`
METHODS = ("rodas4", "ros2")

#: first tolerance of the noise-accurate mode: on the reference rig RODAS4 at 3e-5 meets
#: the default targets (velocity 0.3σ, pressure and flow 0.1σ) with a margin (``make bench``)
NOISE_START_RTOL = 3e-5

#: companion tolerance / run tolerance of the error estimate
COMPANION_RATIO = 10.0

#: tightest tolerance the noise-accurate mode tries before giving up
NOISE_MIN_RTOL = 1e-10

Arr = npt.NDArray[np.float64]

#: slowest sampling grid of a cycle [Hz]: slower grids leave a phase of a few seconds
#: without the samples the error estimate compares
MIN_SAMPLE_RATE = 1.0
#: least rate of the points a sampled cycle's summary is averaged and its error estimated
#: over [Hz]: a table at a coarser rate is a choice of the table only (at 1 Hz the phase
#: averages were those of five samples — meter B 140 σ off, the return's 4× the pump's
#: flow — and the error estimate read 3e-5 σ: a modelling engineer's pass)
AVERAGE_RATE = 1000.0

PHASES = ("working", "return")
#: the relative tolerances a run takes [-]: the service's own bounds (1e-8 and 0.1: ``rtol``
#: of ``POST /simulate``) widened to what the solvers still meet
MIN_RTOL, MAX_RTOL = 1e-12, 0.1
#: a held working phase whose piston ends within this fraction of the stroke from its stop
#: completed its stroke (the end stop's stiffness leaves it a hair short) [-]
HELD_AT_STOP = 1e-3


def phase_settings(rig: Rig, phase: str, overrides: Mapping[str, float] | None = None
                   ) -> dict[str, float]:
    """The parameters one phase sets (paper 002 §3): working, spool at N = +1 from the
    chamber-1 end stop; return, spool at N = −1 from the end of stroke (``overrides``'
    ``cylinder.stroke`` where given) with no load (eq. 52)."""
    check_overrides(overrides)            # the first look at them on every path
    stroke = (overrides or {}).get("cylinder.stroke", rig.base["cylinder.stroke"])
    if phase == "working":
        return {"valve.N": 1.0, "cylinder.x_init": 0.0}
    return {"valve.N": -1.0, "load.force": 0.0, "load.back_pressure": 0.0,
            "cylinder.x_init": stroke}


def phase_params(rig: Rig, phase: str, overrides: Mapping[str, float] | None,
                 condition: Condition) -> Arr:
    """Parameter vector of one phase."""
    if phase not in PHASES:
        raise ValueError(f"unknown phase {phase!r}")
    return rig.params(overrides, condition, phase_settings(rig, phase, overrides))


def stroke_of(rig: Rig, p: Arr) -> float:
    """The stroke [m] of a phase's parameter vector ``p``: an override's, not the stored
    one (a 0.25 m stroke override ran to 45 s of "stall" on the piston's stop, the steady
    path kept the stored 0.5 m's duration: a modelling engineer's pass)."""
    return float(p[rig.model.param_index("cylinder.stroke")])


def _phase_speed(t: npt.NDArray[np.float64], x: npt.NDArray[np.float64], travelled: float,
                 duration: float, completed: bool) -> float:
    """A phase's piston speed [m/s] as an encoder reads it: a completed stroke's
    least-squares slope over the middle of its travel (:func:`~sim.phase_reading.
    steady_slope`, the reading of a measured cycle and what the steady model predicts); a
    stall's or creep's travel over the phase's duration.  Stroke over duration counts the
    start, the oil compressed before the piston moves: 0.09-0.27 % slow in the working
    stroke and 0.05-0.49 % fast in the return on the paper rig and a 160 bar one
    (``python -m benchmarks.speed_readings``), and a rig author's commissioning, fed those
    speeds, moved the seal land 8 % to absorb them."""
    if completed:
        window = steady_window(x)
        if int(window.sum()) >= 3:
            return steady_slope(t[window], x[window])
    return travelled / duration if duration > 0 else 0.0


def _averages(rig: Rig, t: Arr, y: Arr, p: Arr, completed: bool
              ) -> tuple[dict[str, float], dict[str, float]]:
    """Time averages of the outputs as a rig's meters read the phase
    (:mod:`sim.phase_reading`): a completed stroke over the middle of its travel (10-90 %,
    :func:`~sim.phase_reading.steady_window`; the whole phase if the piston travelled too
    little to have a middle), a stroke that stalled or crept short of its end over the
    last half of the phase (:func:`~sim.phase_reading.settled_window`, the settled state:
    10-90 % of a stall's few µm of travel read the start-up transient, 0.6 bar at the pump
    with the relief valve blowing at 71 bar).  Also the lowest value of each pressure
    output over the whole phase [Pa] (what :attr:`PhaseSummary.lowest` keeps)."""
    out = rig.model.outputs(t, y, p)
    sel = (steady_window(y[:, rig.model.state_index("cylinder.x")]) if completed
           else settled_window(t))
    ts = t[sel]
    res: dict[str, float] = {}
    lowest: dict[str, float] = {}
    for j, (name, unit) in enumerate(zip(rig.model.output_names, rig.model.output_units,
                                         strict=True)):
        if name in SUMMARY_UNITS:
            res[name] = time_average(out[sel, j], ts)
        if unit == "Pa":
            lowest[name] = float(np.min(out[:, j]))
    return res, lowest


def phase_limit(rig: Rig, p: Arr, t_max: float | None, limits: SolverLimits,
                phase: str | None = None) -> float:
    """A phase's longest simulated time [s]: ``t_max``, else 20× its stroke at the pump's
    geometric flow — the guard that ends a stall — but no longer than the simulated-time
    limit: a 3 m press whose 80 s cycle has a 1,248 s guard was refused whole (a modelling
    engineer's pass); a stroke cut there, short of its end and of its guard, is a
    :class:`~sim.errors.SolverLimitError` (:func:`integrate_phases`), not a stall."""
    return min(stall_guard(rig, p, t_max, phase), limits.max_sim_time)


def stall_guard(rig: Rig, p: Arr, t_max: float | None = None, phase: str | None = None
                ) -> float:
    """``t_max``, else 20× the phase's stroke time at the pump's geometric flow [s]: a stroke
    that has not ended by then is a stall or a creep (the transient's phase ends there).

    The stroke time is that of the chamber the pump fills: A1 in the working phase, A2 in
    the return (the smaller of the two when ``phase`` is not given).  With min(A1, A2) in
    both, a differential cylinder's working stroke at 22 % of its geometric speed (a 100/90
    cylinder, 5.3:1) was cut as "stalled" 0.42 m into its 0.5 m (an edge pass)."""
    m = rig.model
    if t_max is not None:
        return t_max
    stroke = stroke_of(rig, p)
    qp = p[m.param_index("pump.speed")] * p[m.param_index("pump.Vp")]
    a1, a2 = p[m.param_index("cylinder.A1")], p[m.param_index("cylinder.A2")]
    area = a1 if phase == "working" else a2 if phase == "return" else min(a1, a2)
    return float(20.0 * stroke * area / qp)


@dataclass
class PhaseRun:
    """One phase of :func:`integrate_phases`: parameters, start time and state, result."""

    phase: str
    p: Arr
    t0: float
    y0: Arr
    res: IntegrationResult


def integrate_phases(rig: Rig, params: list[Arr], *, method: str, rtol: float,
                     grid: Arr | None = None, times: list[Arr] | None = None,
                     t_max: float | None = None, limits: SolverLimits | None = None,
                     deadline: float | None = None, hold: bool = False) -> list[PhaseRun]:
    """Both phases, one after the other, each from the state the previous ended in.

    ``params`` holds the phases' parameter vectors (:func:`phase_params`); ``grid`` is
    one sampling grid for both phases, ``times`` one array of output times per phase
    (RODAS4 only; ``None``: every accepted step).  ``hold`` (with ``t_max``): the working
    phase ends at ``t_max`` only, not at the end stop (module docstring).
    """
    limits = limits if limits is not None else SolverLimits()
    m = rig.model
    runs: list[PhaseRun] = []
    y: Arr | None = None
    t0 = 0.0
    for k, (phase, p) in enumerate(zip(PHASES, params, strict=True)):
        if y is None:
            y = m.initial_state(p)
        t_lim = phase_limit(rig, p, t_max, limits, phase)
        direction = 1.0 if phase == "working" else -1.0
        level = stroke_of(rig, p) if phase == "working" else 0.0
        sample = times[k] if times is not None else grid
        held = hold and t_max is not None and phase == "working"
        res = m.integrate(y, p, t0 + t_lim, t0=t0, rtol=rtol, method=method, times=sample,
                          event=None if held else ("cylinder.x", level, direction),
                          limits=limits,
                          deadline=deadline)
        if not res.success:
            raise SolverLimitError(
                f"{phase} phase: the step size fell below round-off at t = "
                f"{res.t_final:.6g} s with rtol {rtol:.3g}; loosen the tolerance",
                field="rtol")
        if res.status != 1 and not held and t_lim < stall_guard(rig, p, t_max, phase):
            # cut by the limit before its own stall guard: no stall can be told
            raise SolverLimitError(
                f"simulated time: the {phase} stroke had not reached its end after "
                f"{t_lim:.4g} s, the simulated-time limit (its stall guard, 20× the stroke's "
                f"time at the pump's flow, is {stall_guard(rig, p, t_max, phase):.4g} s); raise "
                "the limit (HYDRODIAG_SIM_MAX_TIME, or SolverLimits.max_sim_time)")
        runs.append(PhaseRun(phase, p, t0, y, res))
        y = res.y_final.copy()
        t0 = float(res.t_final)
    return runs


def sampled_outputs(runs: list[PhaseRun], rig: Rig) -> list[tuple[Arr, Arr]]:
    """Per phase ``(times [s], outputs)`` of the recorded rows of ``runs``."""
    return [(r.res.t, rig.model.outputs(r.res.t, r.res.y, r.p)) for r in runs]


def _noise_run(rig: Rig, params: list[Arr], accuracy: NoiseAccuracy, rtol: float | None,
               grid: Arr | None, t_max: float | None, limits: SolverLimits,
               deadline: float | None, hold: bool = False) -> tuple[list[PhaseRun], SolverReport]:
    """RODAS4 at a tolerance whose estimated error meets ``accuracy`` (see module notes).

    With ``rtol`` given the run is at that tolerance and only estimated; without, the
    tolerance is tightened (from :data:`NOISE_START_RTOL`, in proportion to the worst
    ratio of estimate to target) until the targets are met.
    """
    m = rig.model
    targets = accuracy.targets(m.output_names, m.output_units)
    r = rtol if rtol is not None else NOISE_START_RTOL
    tries = 0
    while True:
        tries += 1
        main = integrate_phases(rig, params, method="rodas4", rtol=r, grid=grid, times=None,
                          t_max=t_max, limits=limits, deadline=deadline, hold=hold)
        comp = integrate_phases(rig, params, method="rodas4", rtol=COMPANION_RATIO * r, grid=None,
                          times=[run.res.t for run in main], t_max=t_max, limits=limits,
                          deadline=deadline, hold=hold)
        est = error_estimate(sampled_outputs(main, rig), sampled_outputs(comp, rig), COMPANION_RATIO,
                             m.output_names, targets)
        worst = max((est[n] / targets[n][1] for n in est), default=0.0)
        if rtol is not None or worst <= 1.0:
            break
        if r <= NOISE_MIN_RTOL or tries >= 4:
            raise SolverLimitError(
                f"accuracy target not reached: at rtol {r:.3g} the estimated error is "
                f"{worst:.3g}× the target", field="accuracy")
        r = max(NOISE_MIN_RTOL, r * min(1.0 / 3.0, 0.7 / worst))
    switch = abs(main[0].res.t_final - comp[0].res.t_final) / (COMPANION_RATIO - 1.0)
    report = SolverReport(
        "rodas4", r, sum(x.res.rejected for x in main), sum(x.res.nfev for x in main),
        error_sigma=est, target_sigma={n: f for n, (_, f) in targets.items()},
        sigma={n: s for n, (s, _) in targets.items()}, switch_time_error=switch, tries=tries)
    return main, report


def run_cycle(rig: Rig, overrides: Mapping[str, float] | None = None,
              condition: Condition | None = None, *, rtol: float | None = None,
              method: str = "ros2", accuracy: NoiseAccuracy | None = None,
              sample_rate: float | None = None, t_max: float | None = None,
              timeseries: bool = True, limits: SolverLimits | None = None,
              hold: bool = False) -> CycleResult:
    """Simulate one working + return cycle.

    Parameters
    ----------
    rig
        The rig.
    overrides
        Parameter overrides ``role.name → SI value`` (fault scenario).
    condition
        Operating condition (defaults: the rig file's).
    rtol
        Relative tolerance [-].  ``None`` with RODAS4: noise-accurate (the tolerance is
        chosen so that the estimated error meets ``accuracy``, by default
        :class:`~sim.solver.noise.NoiseAccuracy`'s: velocity 0.3σ, pressure and flow
        0.1σ); ``None`` with ROS2: 1e-3.
    method
        ``"rodas4"`` (fourth order, dense output) or ``"ros2"`` (second order; one row per
        step, no sampling, no error estimate).  The library default stays ROS2 at 1e-3 so
        that existing studies (``make accuracy``, sweeps) keep their figures; ``/simulate``
        and ``hydrodiag simulate`` default to noise-accurate RODAS4.
    accuracy
        Error targets in units of sensor noise; with ``rtol`` given, the run is only
        estimated against them (a companion run at 10·rtol).
    sample_rate
        Output on a grid of this rate from t = 0 [Hz], at least :data:`MIN_SAMPLE_RATE`
        (RODAS4's dense output); ``None``:
        one row per accepted step.
    t_max
        Longest phase [s]; default 20× the stroke time at the pump's geometric flow.
    timeseries
        Whether to return the time series table.
    limits
        Step, simulated-time and wall-clock bounds of the run (one wall-clock budget for
        the whole cycle, companion runs included).
    hold
        With ``t_max``: switch the working phase at ``t_max`` only, holding a piston that
        reaches its stop earlier there (a dwell at the end stop, the relief passing the
        pump flow); the return phase still ends at its stop.

    Raises
    ------
    ParameterError
        Unknown method, sampling asked of ROS2, a non-positive sample rate, a sample rate,
        ``rtol`` or ``t_max`` that is no number (``field`` names it).
    SolverLimitError
        A limit of ``limits`` was reached, or the tolerance is below round-off.
    SimulationError
        The solver failed.
    CircuitError
        The rig's circuit has no cylinder cycle.
    """
    require_rig(rig).require_cycle("a cycle simulation")
    # a sample rate "1000" raised a bare TypeError (a library user's pass)
    sample_rate, rtol, t_max = (None if x is None else field_number(x, name, error=ParameterError)
                                for x, name in ((sample_rate, "sample_rate"), (rtol, "rtol"),
                                                (t_max, "t_max")))
    if method not in METHODS:
        raise ParameterError(f"unknown method {method!r} (known: {', '.join(METHODS)})",
                             field="method")
    if method == "ros2" and sample_rate is not None:
        raise ParameterError("sampling on a grid needs the dense output of 'rodas4'",
                             field="sample_rate")
    if sample_rate is not None and not (sample_rate >= MIN_SAMPLE_RATE
                                        and np.isfinite(sample_rate)):
        raise ParameterError(f"the sample rate must be finite and at least {MIN_SAMPLE_RATE:g} "
                             "Hz (a slower grid leaves a phase without samples to compare)",
                             field="sample_rate")
    # unchecked, rtol 1 returned a return speed of 8.5 m/s and P1 483 bar, t_max 0 or NaN an
    # all-zero cycle (a library user's pass)
    if rtol is not None and not (MIN_RTOL <= rtol <= MAX_RTOL):
        raise ParameterError(f"the relative tolerance must lie in [{MIN_RTOL:g}, {MAX_RTOL:g}], "
                             f"not {rtol!r}; None: noise-accurate", field="rtol")
    if t_max is not None and not (np.isfinite(t_max) and t_max > 0.0):
        raise ParameterError(f"t_max must be a finite time > 0 [s], not {t_max!r}",
                             field="t_max")
    lim = limits if limits is not None else SolverLimits()
    deadline = lim.deadline()
    cond = condition if condition is not None else rig.default_condition()
    m = rig.model
    params = [phase_params(rig, phase, overrides, cond) for phase in PHASES]
    grid = shown = None   # the solver's grid, and the table's where it is coarser
    if sample_rate is not None:
        span = sum(phase_limit(rig, p, t_max, lim, phase)
                   for phase, p in zip(PHASES, params, strict=True))
        grid = np.arange(0.0, span, 1.0 / sample_rate)
        if sample_rate < AVERAGE_RATE:  # the averages and the error on a finer grid
            shown = grid
            grid = np.union1d(grid, np.arange(0.0, span, 1.0 / AVERAGE_RATE))
    if method == "ros2":
        r = 1e-3 if rtol is None else rtol
        runs = integrate_phases(rig, params, method="ros2", rtol=r, grid=None, times=None,
                          t_max=t_max, limits=lim, deadline=deadline, hold=hold)
        report = SolverReport("ros2", r, sum(x.res.rejected for x in runs))
    elif rtol is not None and accuracy is None:
        runs = integrate_phases(rig, params, method="rodas4", rtol=rtol, grid=grid, times=None,
                          t_max=t_max, limits=lim, deadline=deadline, hold=hold)
        report = SolverReport("rodas4", rtol, sum(x.res.rejected for x in runs),
                              sum(x.res.nfev for x in runs))
    else:
        runs, report = _noise_run(rig, params, accuracy or NoiseAccuracy(), rtol, grid, t_max,
                                  lim, deadline, hold)
    ix = m.state_index("cylinder.x")
    frames: list[pd.DataFrame] = []
    phases: list[PhaseSummary] = []
    steps: dict[str, int] = {}
    for run in runs:
        res = run.res
        # the averages see the phase's start and end points with the recorded rows
        t_all, y_all = res.t, res.y
        if grid is not None:
            t_all = np.concatenate([[run.t0], res.t, [res.t_final]])
            y_all = np.vstack([run.y0[None, :], res.y, res.y_final[None, :]])
        # a held working phase ends at t_max, not on its event: it completed its stroke if
        # the piston got to its stop (a stroke in 2.42 s held to 5 s read as a stall at
        # 0.100 m/s, its velocity ratio 0.456 for 0.940: a library user's pass)
        completed = res.status == 1 or (
            hold and t_max is not None and run.phase == "working"
            and float(res.y_final[ix]) >= (1.0 - HELD_AT_STOP) * stroke_of(rig, run.p))
        values, lowest = _averages(rig, t_all, y_all, run.p, completed)
        duration = float(res.t_final - run.t0)
        travelled = abs(float(res.y_final[ix] - run.y0[ix]))
        values["duration"] = duration
        values["speed"] = _phase_speed(t_all, y_all[:, ix], travelled, duration, completed)
        phases.append(PhaseSummary(run.phase, values, completed, lowest))
        steps[run.phase] = int(res.steps)
        if timeseries:
            keep = np.isin(res.t, shown) if shown is not None else slice(None)
            out = m.outputs(res.t[keep], res.y[keep], run.p)
            df = pd.DataFrame(out, columns=[f"{n} [{u}]" for n, u in
                                            zip(m.output_names, m.output_units, strict=True)])
            df.insert(0, "t [s]", res.t[keep])
            df.insert(1, "phase", run.phase)
            if frames and not df.empty:
                # step output: the first row is the previous phase's last; a grid point
                # on the switch time is kept once
                df = df[df["t [s]"] > frames[-1]["t [s]"].iloc[-1]] if not frames[-1].empty \
                    else df
            frames.append(df)
    w, r_ = phases
    ratio = w["speed"] / r_["speed"] if r_["speed"] > 0 else float("nan")
    ts = pd.concat(frames, ignore_index=True) if timeseries else None
    return CycleResult(w, r_, ratio, ts, steps, report)
