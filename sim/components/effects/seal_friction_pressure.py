"""Pressure-dependent seal friction: the seal is pressed harder as the chambers' pressure rises.

Bond-graph change: an R (effort out) on the piston-velocity 1-junction ``cylinder.rod``::

    1[ẋ] ── R(F_p)        F_p = k_p·(P1 + P2)·tanh(ẋ/v_s)

The contact force of an elastomer seal grows with the pressure it seals, so its Coulomb
friction does too (Müller & Nau, *Fluid Sealing Technology*, Marcel Dekker 1998, §6.3;
friction ∝ μ_f·π·D·b·p for the pressure-energised lip).  ``k_p`` [m²] is friction
coefficient × contact area; only positive chamber pressures load the seal.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, R, call
from sim.bondgraph.laws import law
from sim.components.base import declare
from sim.components.effects.base import Arr, EffectEntry
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build", "seal_pressure_force"]

NAME = "seal_friction_pressure"

PARAMETERS: tuple[Param, ...] = (
    Param("k_p", "m^2", 0.0, "effect strength, fitted (0 = off)",
          "seal friction per unit chamber pressure (friction coefficient × contact area)",
          lower=0.0, upper=1e-3, lower_inclusive=True),
)


@law
def seal_pressure_force(v: float, P1: float, P2: float, k_p: float, v_s: float) -> float:
    """F = k_p·(max(P1,0) + max(P2,0))·tanh(ẋ/v_s) [N] (Müller & Nau 1998, §6.3)."""
    return k_p * (max(P1, 0.0) + max(P2, 0.0)) * math.tanh(v / v_s)


def _regressor(s: Mapping[str, Arr]) -> Arr:
    load = np.maximum(s["P1"], 0.0) + np.maximum(s["P2"], 0.0)
    return np.asarray(load * np.tanh(s["v"] / 1e-4), dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="seal lips pressed harder at higher chamber pressure: friction grows with P1 + P2",
    reference="Müller & Nau, Fluid Sealing Technology (1998), §6.3",
    circuit="pump-valve-cylinder", balance="piston_force", coefficient="k_p",
    signature="(P1 + P2)·sgn(ẋ)", regressor=_regressor, sign=1.0, plausible=(0.0, 1e-4))


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Add the pressure-loaded seal R on ``cylinder.rod`` (module docstring)."""
    declare(g, name, PARAMETERS, values)
    g.add(R(f"{name}.R", effort=call(seal_pressure_force, "f", "effort:cylinder.c1",
                                     "effort:cylinder.c2", f"p:{name}.k_p", "p:cylinder.v_s"),
            description="pressure-dependent seal friction"))
    g.connect("cylinder.rod", f"{name}.R", label=f"{name}.R")
