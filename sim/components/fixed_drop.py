"""A line section with a constant pressure drop (paper 002 eqs. 8-9: pump outlet → valve inlet).

Bond-graph fragment: a 1-junction between two 0-junctions with an effort source that
subtracts the drop::

    0[up] ─ 1 ─ 0[down]
            │
            Se(−ΔP)

``P_down = P_up − ΔP`` whatever the flow, as the paper models the section
(``PRpv = ΔPpv = const``).  The 1-junction's flow is the flow through the section: with
``down`` the valve inlet it is what the paper's flowmeter B reads.
"""

from __future__ import annotations

from collections.abc import Mapping

from sim.bondgraph import BondGraph, One, Se
from sim.bondgraph.laws import negated
from sim.components.base import Fragment, declare
from sim.params import Param

__all__ = ["PARAMETERS", "build"]

PARAMETERS: tuple[Param, ...] = (
    Param("dp", "Pa", 9.57e4, "paper 002 §2.6 PRpv = 9.57e4 Pa", "constant pressure drop",
          lower_inclusive=True),
)


def build(g: BondGraph, name: str, up: str, down: str,
          values: Mapping[str, float] | None = None) -> Fragment:
    """Add the section between the 0-junctions ``up`` and ``down``; port ``line`` is its 1-junction."""
    declare(g, name, PARAMETERS, values)
    line = f"{name}.line"
    g.add(One(line, description="flow through the section"))
    g.add(Se(f"{name}.drop", negated, f"p:{name}.dp", description="eqs. 8-9"))
    g.connect(up, line)
    g.connect(f"{name}.drop", line)
    g.connect(line, down)
    return Fragment(name, {"line": line})
