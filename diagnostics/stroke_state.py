"""Stroke states of a row of predictions: moving, creeping or held on the end stop.

A stroke's predicted speed is exactly 0 where the piston sits on its end stop (the
end-stop state of :mod:`sim.steady`), below :data:`CREEP` switching speeds of the
Coulomb friction law it creeps (:func:`sim.components.cylinder.friction_force`: the
friction falls from ``Fu`` to 0 over that band, a second kink), else it moves.  The
signature maps split their axes where these states change
(:meth:`diagnostics.signatures.SignatureMaps._ridge_pieces`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sim.rigs import Rig

__all__ = ["CREEP", "SPEED_COLUMNS", "creep_speed", "held_state", "stroke_codes",
           "stroke_states"]

Arr = npt.NDArray[np.float64]

#: a stroke slower than this many switching speeds of the Coulomb friction law
#: (``cylinder.v_s``, :func:`sim.components.cylinder.friction_force`) creeps: friction
#: falls from ``Fu`` (tanh(4) = 0.9993) to 0 over that band, a second kink [-]
CREEP = 4.0
#: columns of the working and return speeds in the maps' observables
#: (:data:`diagnostics.signatures.OBSERVABLES`)
SPEED_COLUMNS = (6, 7)
_SPEEDS = SPEED_COLUMNS


_CREEP_SPEEDS: dict[int, tuple[Rig, float]] = {}


def creep_speed(rig: Rig) -> float:
    """:data:`CREEP` times the rig's friction switching speed [m/s] (kept per rig)."""
    hit = _CREEP_SPEEDS.get(id(rig))
    if hit is None or hit[0] is not rig:
        if len(_CREEP_SPEEDS) > 64:
            _CREEP_SPEEDS.clear()
        hit = (rig, CREEP * float(rig.base["cylinder.v_s"]))
        _CREEP_SPEEDS[id(rig)] = hit
    return hit[1]


def stroke_codes(rows: Arr, creep: float) -> npt.NDArray[np.int64]:
    """:func:`stroke_states` of each row of ``rows`` as one code, ``3·working + return``;
    -1 for a row without prediction."""
    w, r = rows[:, _SPEEDS[0]], rows[:, _SPEEDS[1]]
    with np.errstate(invalid="ignore"):
        ws = np.where(w == 0.0, 2, (w < creep).astype(np.int64))
        rs = np.where(r == 0.0, 2, (r < creep).astype(np.int64))
    code = 3 * ws + rs
    code[~(np.isfinite(w) & np.isfinite(r))] = -1
    return np.asarray(code, dtype=np.int64)


def stroke_states(row: Arr, creep: float) -> tuple[int, int] | None:
    """State of the working and the return stroke of a row of predictions: 0 moving, 1
    creeping (slower than ``creep`` [m/s]), 2 held on its end stop (speed 0); None for a
    row without prediction."""
    st = held_state(row)
    if st is None:
        return None
    w, r = (float(row[i]) for i in _SPEEDS)
    return (2 if st[0] else int(w < creep)), (2 if st[1] else int(r < creep))


def held_state(row: Arr) -> tuple[bool, bool] | None:
    """Whether the working and the return piston of a row of predictions sit on their end
    stops (speed exactly 0, :mod:`sim.steady`); None for a row without prediction."""
    w, r = float(row[_SPEEDS[0]]), float(row[_SPEEDS[1]])
    if not (math.isfinite(w) and math.isfinite(r)):
        return None
    return w == 0.0, r == 0.0
