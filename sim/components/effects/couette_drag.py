"""Viscous (Couette) drag of the piston and rod guides, proportional to oil viscosity.

Bond-graph change: an R (effort out) on the piston-velocity 1-junction ``cylinder.rod``::

    1[ẋ] ── R(F_c)        F_c = k_c·μ(T)·ẋ

A film of thickness h over a guide of diameter D and length L sheared at ẋ carries the
Couette force μ·π·D·L·ẋ/h (Merritt, *Hydraulic Control Systems*, 1967, §4.2; the shear
term of the annular-gap flow).  ``k_c = π·D·L/h`` [m].  The base model's viscous friction
``Kf·ẋ`` does not change with temperature; this one does, which is what splits them on
records at different oil temperatures.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, R, call
from sim.bondgraph.laws import law
from sim.components.base import declare
from sim.components.effects.base import Arr, EffectEntry
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build", "couette_force"]

NAME = "couette_drag"

PARAMETERS: tuple[Param, ...] = (
    Param("k_c", "m", 0.0, "effect strength, fitted (0 = off)",
          "Couette drag geometry π·D·L/h", lower=0.0, upper=1e6, lower_inclusive=True),
)


@law
def couette_force(v: float, k_c: float, mu: float) -> float:
    """F = k_c·μ·ẋ [N] (Merritt 1967, §4.2)."""
    return k_c * mu * v


def _regressor(s: Mapping[str, Arr]) -> Arr:
    return np.asarray(s["mu"] * s["v"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="oil film sheared in the piston/rod guides: drag ∝ viscosity × speed",
    reference="Merritt, Hydraulic Control Systems (1967), §4.2",
    circuit="pump-valve-cylinder", balance="piston_force", coefficient="k_c",
    signature="μ(T)·ẋ", regressor=_regressor, sign=1.0, plausible=(0.0, 5e4))


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Add the Couette R on ``cylinder.rod`` (module docstring)."""
    declare(g, name, PARAMETERS, values)
    g.add(R(f"{name}.R", effort=call(couette_force, "f", f"p:{name}.k_c", "p:fluid.mu"),
            description="Couette drag"))
    g.connect("cylinder.rod", f"{name}.R", label=f"{name}.R")
