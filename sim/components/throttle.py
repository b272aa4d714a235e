"""Throttle (bypass) valve: an adjustable needle orifice between two nodes.

Paper 002 §2.7 opens throttle valves H (across the piston) and I (valve P→T) by half
turns to mimic worn clearances.  The flow is that of a sharp-edged orifice whose area
grows as a power of the opening θ [turns]:

.. math:: Q = K_t\\,\\theta^{n}\\,\\frac{\\Delta P}{(\\Delta P^2 + p_{tr}^2)^{1/4}}

(√ΔP above the transition pressure ``p_tr``).  ``K_t`` and ``n`` describe one throttle;
the rig file fits them to the calibration tables (Tables 2 and 3).
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
    Param("Kt", "m^3/(s*Pa^0.5)", 1.3e-8, "chosen: fitted to the calibration table of the throttle",
          "flow coefficient at one turn"),
    Param("n", "1", 2.0, "chosen: fitted to the calibration table of the throttle",
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
