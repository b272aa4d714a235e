"""The end-stop state of a steady phase: the piston held on the stop it started from.

Where the load is more than the (worn) rig can push, the moving steady solution of a
phase has the piston travel *against* the commanded direction (or there is none).  The
transient model (:func:`sim.cycle.run_cycle`, end stops of
:func:`sim.components.cylinder.end_stop_force`) instead parks the piston on the stop it
started from (the chamber-1 stop, ``x = 0``, in the working phase; ``x = stroke`` in the
return phase) and settles there: ``ẋ = 0``, the stop's reaction takes up the force
balance (paper 002 eq. 35 with ``m·ẍ = 0`` and the stop force as the unknown), and every
other state is steady: the pump flow goes through the leak paths (piston clearance,
eq. 36 with ``ẋ = 0``; spool, pump) and over the relief valve (eq. 6).  That *end-stop
state* is solved here by the steady path's Newton (:mod:`sim.steady`), with the piston's
inertia state (its velocity) frozen at zero (its equation, whose residual is then the net
force on the held piston over its mass, dropped) and the position at the stop.  It is the
phase's operating point when the moving solution runs backwards or fails, and the held
piston is pressed *into* the stop (net force against the commanded direction,
:func:`stop_force` ≥ 0); the point is flagged (:attr:`sim.steady.SteadyPoint.end_stop`),
its speed is 0.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sim.cycle import stroke_of
from sim.errors import SimulationError
from sim.rigs.assembly import Rig

__all__ = ["DIRECTION", "STOP_FROZEN", "held_state", "stop_force", "stop_start"]

Arr = npt.NDArray[np.float64]

#: commanded direction of travel per phase, +1 towards chamber 2 (extension) [-]
DIRECTION: dict[str, float] = {"working": 1.0, "return": -1.0}
#: states held in the end-stop state: the position (at the stop) and the velocity (zero)
STOP_FROZEN = ("cylinder.x", "cylinder.mass")


def stop_force(rig: Rig, phase: str, y: Arr, p: Arr) -> float:
    """Force with which the held piston of state ``y`` presses into its end stop [N].

    The piston's inertia state is its velocity; frozen at zero, its equation's residual
    is the acceleration the net force without the stop would give,
    ``ẍ = (A1·P1 − A2·P2 − F_load)/m`` (paper 002 eq. 35; friction is zero at ``ẋ = 0``,
    the stop's force zero on its face), positive towards chamber 2.  The stop of the phase
    holds the piston against the commanded direction ``d`` (:data:`DIRECTION`), so the
    state is consistent when ``−d·m·ẍ ≥ 0``; that reaction is returned.
    """
    m = rig.model
    f = np.empty_like(y)
    m.module.rhs(0.0, y, p, f)
    mass = float(p[m.param_index("cylinder.mass")])
    return float(-DIRECTION[phase] * mass * f[m.state_index("cylinder.mass")])


def stop_start(rig: Rig, phase: str, y: Arr, p: Arr) -> Arr:
    """``y`` with the piston held on the phase's end stop (the start of the end-stop solve)."""
    m = rig.model
    out = y.copy()
    out[m.state_index("cylinder.mass")] = 0.0
    out[m.state_index("cylinder.x")] = 0.0 if phase == "working" else stroke_of(rig, p)
    return out


def held_state(rig: Rig, phase: str, p: Arr, guesses: list[Arr], tol: float
               ) -> tuple[Arr, float] | None:
    """The end-stop state from the first guess that converges, and its stop reaction
    [N]; None when none converges or the held piston is not pressed into its stop."""
    m = rig.model
    for g in guesses:
        try:
            y = m.steady(stop_start(rig, phase, g, p), p, frozen=STOP_FROZEN, tol=tol)
        except SimulationError:
            continue
        reaction = stop_force(rig, phase, y, p)
        return (y, reaction) if reaction >= 0.0 else None
    return None
