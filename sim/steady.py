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

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sim.cycle import PHASES, SUMMARY_UNITS, CycleResult, PhaseSummary, phase_params
from sim.errors import SimulationError
from sim.rigs.assembly import Condition, Rig

__all__ = ["SteadyPoint", "steady_cycle", "steady_phase"]

Arr = npt.NDArray[np.float64]

_GUESS: dict[tuple[int, str], Arr] = {}


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
