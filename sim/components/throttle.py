"""Throttle (bypass) valve: an adjustable needle orifice between two nodes.

Paper 002 §2.7 opens throttle valves H (across the piston) and I (valve P→T) by half
turns to mimic worn clearances.  The flow is that of a sharp-edged orifice whose area
grows as a power of the opening θ [turns]:

.. math:: Q = K_t\\,\\theta^{n}\\,\\frac{\\Delta P}{(\\Delta P^2 + p_{tr}^2)^{1/4}}

(√ΔP above the transition pressure ``p_tr``).  ``K_t`` and ``n`` describe one throttle;
the rig file fits them to the calibration tables (Tables 2 and 3).

Sources: the orifice law Q = Cd·A·√(2ΔP/ρ) (Merritt, *Hydraulic Control Systems*, Wiley
1967, ch. 3, orifice flow), ``K_t·θⁿ`` standing for Cd·A·√(2/ρ) of a needle whose flow area
grows as a power of its turns (paper 002 gives the throttles no law, only their calibration
tables); the smooth transition ``ΔP/(ΔP² + p_tr²)^{1/4}`` is the 4/2 valve's path law's
(:mod:`sim.components.directional_valve`), keeping dQ/dΔP finite at 0.
"""

from __future__ import annotations

from collections.abc import Mapping

from sim.bondgraph import BondGraph, One, R, call
from sim.bondgraph.laws import law
from sim.components.base import Fragment, declare
from sim.params import Param

__all__ = ["PARAMETERS", "build", "throttle_flow"]

PARAMETERS: tuple[Param, ...] = (
    Param("opening", "1", 0.0, "closed: the rig runs with the throttles shut", "opening θ [turns]",
          lower_inclusive=True, upper=10.0),
    Param("Kt", "m^3/(s*Pa^0.5)", 1.3e-8, "chosen: a placeholder of a throttle's size; a rig "
          "states its own (the reference rig: throttle I 1.72e-8 fitted to paper 002 Table 3, "
          "throttle H 4.8e-8 of Table 2's shape)",
          "flow coefficient at one turn"),
    Param("n", "1", 2.0, "chosen: an opening area rising with the square of the turns (the "
          "reference rig's throttle I, fitted to paper 002 Table 3)",
          "exponent of the opening-area law"),
    Param("p_tr", "Pa", 2.0e3, "chosen: laminar-turbulent transition pressure", "transition pressure"),
)


@law
def throttle_flow(dp: float, Kt: float, n: float, opening: float, p_tr: float) -> float:
    """Flow [m³/s] through the throttle at drop ``dp`` [Pa] and opening [turns]."""
    if opening <= 0.0:
        return 0.0
    return Kt * opening**n * dp / (dp * dp + p_tr * p_tr) ** 0.25


def build(g: BondGraph, name: str, a: str, b: str, values: Mapping[str, float] | None = None
          ) -> Fragment:
    """Add a throttle from 0-junction ``a`` to 0-junction ``b``."""
    declare(g, name, PARAMETERS, values)
    j = f"{name}.path"
    g.add(One(j))
    g.add(R(f"{name}.R", flow=call(throttle_flow, "e", f"p:{name}.Kt", f"p:{name}.n",
                                   f"p:{name}.opening", f"p:{name}.p_tr")))
    g.connect(a, j)
    g.connect(j, f"{name}.R")
    g.connect(j, b)
    return Fragment(name, {"a": a, "b": b, "path": j})
