"""Pressure relief valve (paper 002 eq. 6), with optional seat leakage.

Bond-graph fragment: an R on a branch from the protected 0-junction to tank::

    0[Pp] ─ 1 ─ R_rv

``Qrv = 0`` for ``Pp < Pset`` and ``(Pp − Pset)/Rrv`` above (eq. 6).  A faulty valve has a
setting that has drifted (``Pset`` lower) or a seat that leaks (a seat conductance
``Gseat`` > 0 [m³/(s·Pa)]): then ``Gseat·Pp`` flows to tank at every pressure (the
project's addition: paper 002's valve has no seat leak).
"""

from __future__ import annotations

from collections.abc import Mapping

from sim.bondgraph import BondGraph, R, call
from sim.bondgraph.laws import law
from sim.components.base import Fragment, declare
from sim.params import Param, Relation, at_least, at_most

__all__ = ["PARAMETERS", "RELATIONS", "build", "relief_flow"]

PARAMETERS: tuple[Param, ...] = (
    Param("Pset", "Pa", 7.0e6, "paper 002 §2.6 Pset = 7.0e6 Pa", "opening pressure"),
    Param("Rrv", "Pa*s/m^3", 2.5e9, "paper 002 §2.6 Rrv = 2.5e9 Pa·s/m³", "resistance above opening"),
    Param("Gseat", "m^3/(s*Pa)", 0.0, "chosen: a healthy seat does not leak",
          "seat-leakage conductance", lower_inclusive=True),
)

#: Plausibility: a setting within what hydraulic valves are built for.
RELATIONS: tuple[Relation, ...] = (
    at_most("Pset", 1.5e8, "Pa", "1500 bar; ultra-high-pressure tools work at 700-1000 bar"),
    at_least("Pset", 1.0e5, "Pa", "1 bar; a relief below a supply line's own drop protects "
             "nothing and stops the actuator"),
)


@law
def relief_flow(p: float, Pset: float, Rrv: float, Gseat: float) -> float:
    """Flow through the relief valve [m³/s] at inlet pressure ``p`` [Pa] (paper 002 eq. 6).

    ``Gseat`` is the seat-leakage conductance [m³/(s·Pa)] (0 for a healthy valve).
    """
    q = Gseat * p
    if p > Pset:
        q += (p - Pset) / Rrv
    return q


def build(g: BondGraph, name: str, node: str, values: Mapping[str, float] | None = None) -> Fragment:
    """Add the relief valve from the 0-junction ``node`` to tank."""
    declare(g, name, PARAMETERS, values)
    g.add(R(name, flow=call(relief_flow, "e", f"p:{name}.Pset", f"p:{name}.Rrv",
                            f"p:{name}.Gseat"), description="eq. 6"))
    g.connect(node, name, label=name)
    g.output("Q_relief", f"f:{name}", "m^3/s", "flow through the relief valve")
    return Fragment(name, {"in": node})
