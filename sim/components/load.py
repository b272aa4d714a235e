"""External load on the cylinder: a force on the piston, or a back-pressure in a line.

Paper 002 applies the load with an electrically operated load control valve that
creates a back-pressure of 10, 20 or 30 bar; the model represents it as an equivalent
force ``SeF_load`` of 2.1, 4.2 or 6.3 kN on the piston (eqs. 28, 38; zero in the return
phase, eq. 52).  Both forms are available:

* ``force``: an effort source on the piston's 1-junction, ``F = −F_load`` (it resists
  extension);
* ``back_pressure``: an effort source on a line's 1-junction that raises the pressure
  upstream of it by ``p_back`` when the oil flows against the line's bond direction
  (out of the cylinder), as a load valve in the outlet line does.
"""

from __future__ import annotations

from collections.abc import Mapping

from sim.bondgraph import BondGraph, Se
from sim.bondgraph.laws import constant, negated
from sim.components.base import Fragment, declare
from sim.params import Param

__all__ = ["PARAMETERS", "build"]

PARAMETERS: tuple[Param, ...] = (
    Param("force", "N", 2.1e3, "paper 002 §3: 2.1/4.2/6.3 kN",
          "load force resisting extension (negative: an overrunning load)",
          lower=-1.0e6, upper=1.0e6, lower_inclusive=True),
    Param("back_pressure", "Pa", 0.0, "paper 002 §3: 10/20/30 bar via the load control valve",
          "back-pressure in the cylinder's outlet line", lower=-1.0e5, upper=5.0e7,
          lower_inclusive=True),
)


def build(g: BondGraph, name: str, rod: str, outlet_line: str,
          values: Mapping[str, float] | None = None) -> Fragment:
    """Add the force on the 1-junction ``rod`` and the back-pressure on ``outlet_line``."""
    declare(g, name, PARAMETERS, values)
    g.add(Se(f"{name}.F", negated, f"p:{name}.force", description="SeF_load, eqs. 28/38"))
    g.connect(f"{name}.F", rod)
    g.add(Se(f"{name}.bp", constant, f"p:{name}.back_pressure", description="load valve"))
    g.connect(f"{name}.bp", outlet_line)
    return Fragment(name, {"rod": rod, "line": outlet_line})
