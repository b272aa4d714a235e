"""Stribeck friction of the piston seal: extra breakaway force decaying with speed.

Bond-graph change: an R (effort out) on the piston-velocity 1-junction ``cylinder.rod``::

    1[ẋ] ── R(F_st)        F_st = F_s·exp(−(ẋ/v_st)²)·tanh(ẋ/v_s)

The base rig has Coulomb + viscous friction (paper 002 eq. 37); real seals show a higher
static (breakaway) friction that falls off over a Stribeck speed (Armstrong-Hélouvry,
Dupont, Canudas de Wit, *Automatica* 30(7), 1994, eq. 7, Gaussian Stribeck curve).
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

__all__ = ["ENTRY", "PARAMETERS", "build", "stribeck_force"]

NAME = "stribeck_friction"

PARAMETERS: tuple[Param, ...] = (
    Param("F_s", "N", 0.0, "effect strength, fitted (0 = off)",
          "Stribeck excess of breakaway over Coulomb friction", lower=0.0, upper=1.0e5,
          lower_inclusive=True),
    Param("v_st", "m/s", 0.02, "chosen: ~1/10 of the paper-002 working speed (0.2 m/s); "
          "Armstrong-Hélouvry 1994 Table 1 gives 1e-4..0.1 m/s", "Stribeck speed",
          lower=1e-5, upper=1.0),
)


@law
def stribeck_force(v: float, F_s: float, v_st: float, v_s: float) -> float:
    """Stribeck excess force F = F_s·exp(−(ẋ/v_st)²)·tanh(ẋ/v_s) [N] (Armstrong-Hélouvry 1994, eq. 7).

    ``v`` is the piston speed [m/s]; ``v_s`` [m/s] the smoothing speed of sgn(ẋ) of the
    base friction law (``cylinder.v_s``).
    """
    return F_s * math.exp(-(v / v_st) ** 2) * math.tanh(v / v_s)


def _regressor(s: Mapping[str, Arr]) -> Arr:
    v = s["v"]
    return np.asarray(np.exp(-(v / 0.02) ** 2) * np.tanh(v / 1e-4), dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="breakaway friction of the piston seal above Coulomb, fading over a Stribeck speed",
    reference="Armstrong-Hélouvry, Dupont, Canudas de Wit, Automatica 30(7) 1994, eq. 7",
    circuit="pump-valve-cylinder", balance="piston_force", coefficient="F_s",
    signature="exp(−(ẋ/v_st)²)·sgn(ẋ)", regressor=_regressor, sign=1.0,
    plausible=(0.0, 2000.0), window="slow")


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Add the Stribeck R on ``cylinder.rod`` (module docstring)."""
    declare(g, name, PARAMETERS, values)
    p = f"p:{name}."
    g.add(R(f"{name}.R", effort=call(stribeck_force, "f", p + "F_s", p + "v_st",
                                     "p:cylinder.v_s"), description="Stribeck excess friction"))
    g.connect("cylinder.rod", f"{name}.R", label=f"{name}.R")
