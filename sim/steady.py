"""Steady-state fast path: each phase's operating point as an algebraic system.

In the middle of a stroke the rig runs at a steady operating point: every pressure,
flow and the piston speed are constant while the position grows linearly.  Setting the
derivatives of all storage states to zero (the position is held at mid-stroke; at steady
state no equation depends on it, since ``dP/dt = 0`` makes the chamber volume irrelevant)
gives an algebraic system of the same compiled right-hand side, solved by damped Newton
(:func:`sim.solver.rosenbrock.steady`) in tens of microseconds.

A good first guess matters for Newton.  Per rig and phase the nominal operating point is
found once by a short transient from rest (pseudo-transient continuation) and then used
as the starting point of every later solve (continuation from the nominal point); if
Newton fails from there, the transient start is repeated with the new parameters.

The phase averages of :func:`sim.cycle.run_cycle` agree with these operating points
(the tests hold them to 0.5 % over faults and loads; a numerics pass measured ≤ 8.2e-5
relative, 0.057 of the instruments' uncertainty, over 11 conditions): the start-up
transient lasts milliseconds against phases of seconds.

End stops
---------
Where the load is more than the (worn) rig can push, the moving steady solution of a
phase has the piston travel *against* the commanded direction (or there is none); the
phase's operating point is then the *end-stop state* of :mod:`sim.end_stop`, the piston
held on the stop it started from as the transient model parks it, flagged
(:attr:`SteadyPoint.end_stop`), its speed 0.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sim.cycle import (
    PHASES,
    SUMMARY_UNITS,
    CycleResult,
    PhaseSummary,
    phase_params,
    stall_guard,
    stroke_of,
)
from sim.end_stop import DIRECTION, held_state, stop_force
from sim.errors import InputError, SimulationError
from sim.rigs.assembly import Condition, Rig, require_rig

__all__ = ["DIRECTION", "OBSERVABLES", "SteadyEvaluator", "SteadyPoint", "steady_cycle",
           "steady_phase", "stop_force"]

Arr = npt.NDArray[np.float64]

#: nominal operating point per (rig, phase) — the moving piston's at the rig's default
#: condition, without overrides (:func:`_nominal_guess`) —, the first guess of every solve
#: (bounded); the rig is kept with it, so a new rig that reuses a collected rig's ``id``
#: does not start from that rig's point.  Until a determinism pass it was the first point
#: any caller asked for, so every later answer depended, to the solver's tolerance, on
#: what a process had solved first (1e-7 relative in a diagnosis: a batch on a process
#: pool against the same batch in the process that had made the records)
_GUESS: OrderedDict[tuple[int, str], tuple[Rig, Arr]] = OrderedDict()
_GUESS_SIZE = 128
_T0 = np.zeros(1)


@dataclass
class SteadyPoint:
    """Steady operating point of one phase: the state and the outputs."""

    phase: str
    state: Arr
    outputs: dict[str, float]
    #: the piston sits on its end stop (the end-stop state, module docstring)
    end_stop: bool = False
    #: reaction of the end stop on the piston, pushing against the load [N] (0 when moving)
    stop_reaction: float = 0.0
    #: the transient's stall guard for this phase [s] (:func:`sim.cycle.stall_guard`): a
    #: stroke slower than it is no completed stroke
    guard: float = float("inf")

    @property
    def speed(self) -> float:
        """Piston speed magnitude [m/s]."""
        return abs(self.outputs["v"])


def _transient_start(rig: Rig, p: Arr) -> Arr:
    m = rig.model
    y0 = m.initial_state(p)
    res = m.integrate(y0, p, 0.3, rtol=1e-4)
    if not res.success:
        raise SimulationError(f"no start-up transient (status {res.status})")
    return res.y[-1].copy()


def _nominal_guess(rig: Rig, phase: str) -> Arr | None:
    """The moving piston's steady state of ``phase`` at the rig's default condition, no
    overrides, from the start-up transient (cached per rig, :data:`_GUESS`); None where
    there is none (every solve then starts from its own transient).  A function of the
    rig alone, so that a solve started from it does not depend on what was solved
    before."""
    key = (id(rig), phase)
    hit = _GUESS.get(key)
    if hit is not None and hit[0] is rig:
        return hit[1]
    m = rig.model
    p = phase_params(rig, phase, None, rig.default_condition())
    try:
        start = _transient_start(rig, p)
        start[m.state_index("cylinder.x")] = 0.5 * stroke_of(rig, p)
        y = m.steady(start, p, frozen=("cylinder.x",), tol=1e-10)
    except SimulationError:
        return None
    _GUESS[key] = (rig, y.copy())
    while len(_GUESS) > _GUESS_SIZE:
        _GUESS.popitem(last=False)
    return y


def steady_phase(rig: Rig, phase: str, overrides: Mapping[str, float] | None = None,
                 condition: Condition | None = None, *, tol: float = 1e-10) -> SteadyPoint:
    """Steady operating point of ``phase`` ("working" or "return"): the moving piston's,
    or the end-stop state (module docstring) where the moving solution runs against the
    commanded direction or is not found.

    Raises
    ------
    InputError
        ``rig`` is no compiled rig, ``phase`` none of "working", "return" (``field``
        names the argument); a parameter error naming an override or the condition.
    SimulationError
        If neither a moving steady point nor a consistent end-stop state is found.
    """
    require_rig(rig)
    if not (isinstance(phase, str) and phase in PHASES):  # "work" raised a bare ValueError
        raise InputError(f"unknown phase {phase!r} (one of: {', '.join(PHASES)})",
                         field="phase")
    rig.require_cycle("a steady phase")
    cond = condition if condition is not None else rig.default_condition()
    m = rig.model
    p = phase_params(rig, phase, overrides, cond)
    ix = m.state_index("cylinder.x")
    iv = m.output_names.index("v")
    mid = 0.5 * stroke_of(rig, p)
    guess = _nominal_guess(rig, phase)
    y: Arr | None = None
    if guess is not None:
        # at this stroke's middle: the guess of a longer stroke left the piston beyond a
        # shorter one's end stop, pushed back, and a 0.2 m stroke after the nominal 0.5 m
        # had "no steady operating point" (an edge pass; order-dependent in the tests too)
        guess = guess.copy()
        guess[ix] = mid
        try:
            y = m.steady(guess, p, frozen=("cylinder.x",), tol=tol)
        except SimulationError:
            y = None
    start: Arr | None = None
    if y is None:
        start = _transient_start(rig, p)
        moving = start.copy()
        moving[ix] = mid
        try:
            y = m.steady(moving, p, frozen=("cylinder.x",), tol=tol)
        except SimulationError:
            y = None
    if y is not None:
        out = m.outputs(np.zeros(1), y[None, :], p)[0]
        if DIRECTION[phase] * out[iv] >= 0.0:
            return SteadyPoint(phase, y, dict(zip(m.output_names, map(float, out), strict=True)),
                               guard=stall_guard(rig, p, phase=phase))
    guesses = [g for g in (y, start) if g is not None]
    if start is None:
        guesses.append(_transient_start(rig, p))
    held = held_state(rig, phase, p, guesses, tol)
    if held is None:
        raise SimulationError(f"{phase}: no steady operating point (the moving piston "
                              + ("runs against the commanded direction" if y is not None else
                                 "has none") + " and no end-stop state holds)")
    ys, reaction = held
    out = m.outputs(np.zeros(1), ys[None, :], p)[0]
    return SteadyPoint(phase, ys, dict(zip(m.output_names, map(float, out), strict=True)),
                       end_stop=True, stop_reaction=reaction,
                       guard=stall_guard(rig, p, phase=phase))


def steady_cycle(rig: Rig, overrides: Mapping[str, float] | None = None,
                 condition: Condition | None = None) -> CycleResult:
    """Both phases' operating points, in the shape of :func:`sim.cycle.run_cycle`'s result.

    Durations are ``stroke / speed`` (start-up transients neglected).

    Raises
    ------
    InputError
        ``rig`` is no compiled rig (``field="rig"``); a parameter error naming an override
        or the condition.
    SimulationError
        If a phase has no steady point (:func:`steady_phase`).
    """
    require_rig(rig)
    rig.require_cycle("a steady cycle")
    summaries = []
    for phase in PHASES:
        sp = steady_phase(rig, phase, overrides, condition)   # checks the overrides first
        stroke = (overrides or {}).get("cylinder.stroke", rig.base["cylinder.stroke"])
        vals = {k: sp.outputs[k] for k in SUMMARY_UNITS if k in sp.outputs}
        vals["speed"] = sp.speed
        vals["duration"] = stroke / sp.speed if sp.speed > 0 else float("inf")
        # a creep slower than the transient's stall guard is no completed stroke there, nor
        # here (a 2.9 h creep at 150 °C read completed here, a stall there: a modelling
        # engineer's pass)
        summaries.append(PhaseSummary(phase, vals, sp.speed > 0 and not sp.end_stop
                                      and vals["duration"] <= sp.guard))
    w, r = summaries
    ratio = w["speed"] / r["speed"] if r["speed"] > 0 else float("nan")
    return CycleResult(w, r, ratio, None, {})


#: observable name → (phase, output name); the observables a diagnosis compares
OBSERVABLES: dict[str, tuple[str, str]] = {
    "pump_pressure": ("working", "P_pump"),
    "p1": ("working", "P1"),
    "p2": ("working", "P2"),
    "flow_B": ("working", "Q_meter_B"),
    "flow_C": ("working", "Q_meter_C"),
    "pump_leak": ("working", "Q_pump_leak"),
    "relief_flow": ("working", "Q_relief"),
    "cyl_leak": ("working", "Q_cyl_leak"),
    "valve_leak": ("working", "Q_valve_leak"),
}


class SteadyEvaluator:
    """Repeated steady-cycle evaluations of one rig at one condition, fast.

    The two phases' parameter vectors are built once; each call patches the named graph
    parameters (``"cylinder.cc"``, ``"pump.Rlp"`` ...) and solves both operating points by
    Newton from the last solution (continuation), falling back to the nominal point and
    then to a start-up transient; a phase whose piston cannot travel in its commanded
    direction gets its end-stop state (speed 0; module docstring).  This is what a
    diagnosis calls hundreds of times.

    Parameters
    ----------
    rig
        The rig.
    condition
        Operating condition.
    names
        Graph parameters that calls will set, in order.  They must not feed derived
        parameters (clearances, leak resistances and relief settings do not).
    """

    def __init__(self, rig: Rig, condition: Condition | None, names: tuple[str, ...]) -> None:
        self.rig = rig
        self.condition = condition if condition is not None else rig.default_condition()
        m = rig.model
        self._m = m
        self.names = names
        self._idx = np.array([m.param_index(n) for n in names], dtype=np.int64)
        self._p = {ph: phase_params(rig, ph, None, self.condition) for ph in PHASES}
        self._nominal = {ph: steady_phase(rig, ph, None, self.condition).state for ph in PHASES}
        self._last = {ph: y.copy() for ph, y in self._nominal.items()}
        self._mask = np.ones(len(m.state_names), dtype=np.int64)
        self._mask[m.state_index("cylinder.x")] = 0
        self._imom = m.state_index("cylinder.mass")
        self._stop_mask = self._mask.copy()
        self._stop_mask[self._imom] = 0
        self._nout = len(m.output_names)
        self._oidx = {n: i for i, n in enumerate(m.output_names)}
        self.stroke = rig.base["cylinder.stroke"]
        self.calls = 0

    def rewind(self) -> None:
        """Start the next solve from the healthy operating points again, as a new evaluator
        would: each solve starts from the last one's solution (and tries a stop the piston
        was held on last first), so without this an answer depends on what was solved
        before."""
        self.load(self._nominal)

    def saved(self) -> dict[str, npt.NDArray[np.float64]]:
        """Copies of the last solutions, per phase, the next solve starts from."""
        return {ph: y.copy() for ph, y in self._last.items()}

    def load(self, saved: dict[str, npt.NDArray[np.float64]]) -> None:
        """Start the next solve from ``saved`` (:meth:`saved`)."""
        self._last = {ph: y.copy() for ph, y in saved.items()}

    def nominal(self) -> dict[str, float]:
        """Observables at the rig's own parameter values."""
        return self(np.array([self._p["working"][i] for i in self._idx]))

    def _held(self, phase: str, guess: Arr, p: Arr, y: Arr) -> bool:
        """The end-stop state from ``guess`` into ``y`` (velocity frozen at 0, the position
        left where it is: no steady equation depends on it); True when it converged and
        the held piston is pressed into its stop (:func:`stop_force`)."""
        mod = self._m.module
        start = guess.copy()
        start[self._imom] = 0.0
        status, _, _ = mod.steady(start, p, self._stop_mask, self._m.scale, 1e-10, 60, y)
        if status != 0:
            return False
        f = np.empty_like(y)
        mod.rhs(0.0, y, p, f)
        return bool(-DIRECTION[phase] * f[self._imom] >= 0.0)

    def _solve(self, phase: str, p: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The phase's operating point: a piston held on its stop last time is tried on
        the stop first; else the moving point (last, nominal, start-up transient), kept
        when it travels in the commanded direction; else the end-stop state."""
        mod = self._m.module
        y = np.empty_like(self._last[phase])
        last = self._last[phase]
        if last[self._imom] == 0.0 and self._held(phase, last, p, y):
            self._last[phase] = y.copy()
            return y
        moving: Arr | None = None
        for guess in (last, self._nominal[phase]):
            status, _, _ = mod.steady(guess, p, self._mask, self._m.scale, 1e-10, 60, y)
            if status == 0:
                moving = y.copy()
                break
        start: Arr | None = None
        if moving is None:
            start = _transient_start(self.rig, p)
            start[self._m.state_index("cylinder.x")] = 0.5 * self.stroke
            if mod.steady(start, p, self._mask, self._m.scale, 1e-10, 60, y)[0] == 0:
                moving = y.copy()
        if moving is not None and DIRECTION[phase] * moving[self._imom] >= 0.0:
            self._last[phase] = moving
            return moving
        for held in (moving, last, self._nominal[phase], start):
            if held is not None and self._held(phase, held, p, y):
                self._last[phase] = y.copy()
                return y
        raise SimulationError(f"{phase}: no steady operating point (moving: "
                              + ("runs against the commanded direction" if moving is not None
                                 else "not found") + "; no end-stop state holds)")

    def phase_outputs(self, values: npt.ArrayLike
                      ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Model outputs (``rig.model.output_names``) of the working and return operating
        points for the parameter ``values`` (SI, in the order of ``names``)."""
        vals = np.asarray(values, dtype=float)
        self.calls += 1
        outs = []
        for ph in PHASES:
            p = self._p[ph].copy()
            p[self._idx] = vals
            y = self._solve(ph, p)
            out = np.empty((1, self._nout))  # per call: evaluators may be shared by threads
            self._m.module.outputs_batch(_T0, y[None, :], p, out)
            outs.append(out[0])
        return outs[0], outs[1]

    def _value(self, key: str, w: npt.NDArray[np.float64], r: npt.NDArray[np.float64]) -> float:
        iv = self._oidx["v"]
        # speeds positive in each phase's direction of travel, 0 on the end stop
        if key == "speed_work":
            return float(w[iv])
        if key == "speed_return":
            return float(-r[iv])
        if key == "velocity_ratio":
            return float(w[iv] / -r[iv]) if r[iv] < 0 else float("nan")
        if key == "pump_flow":
            return float(w[self._oidx["Q_meter_B"]] + w[self._oidx["Q_relief"]])
        if key in ("duration_work", "duration_return"):
            v = float(w[iv]) if key == "duration_work" else float(-r[iv])
            return self.stroke / v if v > 0 else float("inf")
        return float(w[self._oidx[OBSERVABLES[key][1]]])

    def vector(self, values: npt.ArrayLike, keys: tuple[str, ...]) -> npt.NDArray[np.float64]:
        """The observables ``keys`` (names of :meth:`__call__`'s mapping) as an array."""
        w, r = self.phase_outputs(values)
        return np.array([self._value(k, w, r) for k in keys])

    def __call__(self, values: npt.ArrayLike) -> dict[str, float]:
        """Observables (see :data:`OBSERVABLES`, plus speeds, ratio, durations, pump flow)
        for the parameter ``values`` (SI, in the order of ``names``).

        Speeds are positive in each phase's direction of travel and 0 where the piston
        sits on its end stop (a stalled stroke; the velocity ratio is NaN where the return
        stroke is held, 0 where the working stroke is).
        """
        w, r = self.phase_outputs(values)
        keys = (*OBSERVABLES, "pump_flow", "speed_work", "speed_return", "velocity_ratio",
                "duration_work", "duration_return")
        return {k: self._value(k, w, r) for k in keys}
