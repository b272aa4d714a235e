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
(tested over faults and loads to 0.5 %): the start-up transient lasts milliseconds
against phases of seconds.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sim.cycle import PHASES, SUMMARY_UNITS, CycleResult, PhaseSummary, phase_params
from sim.errors import SimulationError
from sim.rigs.assembly import Condition, Rig

__all__ = ["OBSERVABLES", "SteadyEvaluator", "SteadyPoint", "steady_cycle", "steady_phase"]

Arr = npt.NDArray[np.float64]

#: nominal operating point per (rig, phase), the first guess of later solves (bounded)
_GUESS: OrderedDict[tuple[int, str], Arr] = OrderedDict()
_GUESS_SIZE = 128
_T0 = np.zeros(1)


@dataclass
class SteadyPoint:
    """Steady operating point of one phase: the state and the outputs."""

    phase: str
    state: Arr
    outputs: dict[str, float]

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


def steady_phase(rig: Rig, phase: str, overrides: Mapping[str, float] | None = None,
                 condition: Condition | None = None, *, tol: float = 1e-10) -> SteadyPoint:
    """Steady operating point of ``phase`` ("working" or "return").

    Raises
    ------
    SimulationError
        If no steady point is found (for instance a piston that stalls on its end stop).
    """
    if phase not in PHASES:
        raise ValueError(f"unknown phase {phase!r}")
    cond = condition if condition is not None else rig.default_condition()
    m = rig.model
    p = phase_params(rig, phase, overrides, cond)
    ix = m.state_index("cylinder.x")
    mid = 0.5 * rig.base["cylinder.stroke"]
    key = (id(rig), phase)
    guess = _GUESS.get(key)
    y: Arr | None = None
    if guess is not None:
        try:
            y = m.steady(guess, p, frozen=("cylinder.x",), tol=tol)
        except SimulationError:
            y = None
    if y is None:
        start = _transient_start(rig, p)
        start[ix] = mid
        y = m.steady(start, p, frozen=("cylinder.x",), tol=tol)
        if guess is None:
            _GUESS[key] = y.copy()
            while len(_GUESS) > _GUESS_SIZE:
                _GUESS.popitem(last=False)
    out = m.outputs(np.zeros(1), y[None, :], p)[0]
    return SteadyPoint(phase, y, dict(zip(m.output_names, map(float, out), strict=True)))


def steady_cycle(rig: Rig, overrides: Mapping[str, float] | None = None,
                 condition: Condition | None = None) -> CycleResult:
    """Both phases' operating points, in the shape of :func:`sim.cycle.run_cycle`'s result.

    Durations are ``stroke / speed`` (start-up transients neglected).
    """
    stroke = rig.base["cylinder.stroke"]
    summaries = []
    for phase in PHASES:
        sp = steady_phase(rig, phase, overrides, condition)
        vals = {k: sp.outputs[k] for k in SUMMARY_UNITS if k in sp.outputs}
        vals["speed"] = sp.speed
        vals["duration"] = stroke / sp.speed if sp.speed > 0 else float("inf")
        summaries.append(PhaseSummary(phase, vals, sp.speed > 0))
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
    then to a start-up transient.  This is what a diagnosis calls hundreds of times.

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
        self._nout = len(m.output_names)
        self._oidx = {n: i for i, n in enumerate(m.output_names)}
        self.stroke = rig.base["cylinder.stroke"]
        self.calls = 0

    def nominal(self) -> dict[str, float]:
        """Observables at the rig's own parameter values."""
        return self(np.array([self._p["working"][i] for i in self._idx]))

    def _solve(self, phase: str, p: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        mod = self._m.module
        y = np.empty_like(self._last[phase])
        for guess in (self._last[phase], self._nominal[phase]):
            status, _, _ = mod.steady(guess, p, self._mask, self._m.scale, 1e-10, 60, y)
            if status == 0:
                self._last[phase] = y.copy()
                return y
        start = _transient_start(self.rig, p)
        start[self._m.state_index("cylinder.x")] = 0.5 * self.stroke
        status, its, res = mod.steady(start, p, self._mask, self._m.scale, 1e-10, 60, y)
        if status != 0:
            raise SimulationError(f"{phase}: steady state not found ({its} iterations, "
                                  f"residual {res:.3g})")
        self._last[phase] = y.copy()
        return y

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
        # signed speeds: positive in each phase's own direction (a piston that cannot hold
        # its load in the working phase moves backwards and reads negative)
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

        Speeds are signed, positive in each phase's direction of travel, so the maps stay
        smooth through a stall.
        """
        w, r = self.phase_outputs(values)
        keys = (*OBSERVABLES, "pump_flow", "speed_work", "speed_return", "velocity_ratio",
                "duration_work", "duration_return")
        return {k: self._value(k, w, r) for k in keys}
