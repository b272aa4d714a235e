"""Hose or line section with resistance, compliance and inertance (lumped, one segment).

Bond-graph fragment (the C sits on the upstream 0-junction, R and I on the line)::

    0[up] ─ 1[line] ─ (downstream 0-junction, connected by the caller)
    │ C        │ I  R

* laminar resistance (Hagen-Poiseuille): ``R = 128·μ·L / (π·d⁴)`` [Pa·s/m³]
* compliance of the oil in the hose: ``C = (π·d²/4)·L / β`` [m³/Pa]
* inertance of the oil column: ``I = ρ·L / (π·d²/4)`` [kg/m⁴]

Paper 000 §4 models hose sections the same way (R, C, I from diameter, length and bulk
modulus); the hose wall's own compliance is folded into the effective β.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from sim.bondgraph import BondGraph, C, I, One, R, call
from sim.bondgraph.laws import constant, linear_effort, linear_flow
from sim.components.base import Fragment, declare
from sim.params import Param

__all__ = ["PARAMETERS", "build", "hose_coefficients"]

PARAMETERS: tuple[Param, ...] = (
    # upper bounds: hydraulic hoses and tubes reach a few inches of bore (ISO 18752: 51 mm)
    # and tens of metres; a bore of 12.7 typed in metres for millimetres was stored and
    # simulated as a 150 m³ hose (a user pass)
    Param("d", "m", 0.0127, "chosen: ½-inch (12.7 mm) bore hose; paper 002 gives no hose data",
          "inner diameter", upper=0.2),
    Param("L", "m", 0.5, "chosen: 0.5 m between valve and cylinder", "length", upper=200.0),
)


def hose_coefficients(d: float, L: float, mu: float, rho: float, beta: float
                      ) -> tuple[float, float, float]:
    """(R [Pa·s/m³], C [m³/Pa], I [kg/m⁴]) of a hose of bore ``d`` [m] and length ``L`` [m]."""
    area = math.pi * d * d / 4.0
    return 128.0 * mu * L / (math.pi * d**4), area * L / beta, rho * L / area


def build(g: BondGraph, name: str, up: str, values: Mapping[str, float] | None = None) -> Fragment:
    """Add a hose whose upstream end is the 0-junction ``up``; port ``line`` is its 1-junction.

    The caller connects ``line`` to the downstream 0-junction (bond line → node).
    """
    declare(g, name, PARAMETERS, values)
    for k in ("R", "C", "I"):
        g.parameter(f"{name}.{k}", 1.0, "", "derived from d, L and the fluid")
    line = f"{name}.line"
    g.add(C(f"{name}.C", constant, f"p:{name}.C", scale=1e5, description="oil compliance"))
    g.add(One(line))
    g.add(I(f"{name}.I", constant, f"p:{name}.I", scale=1e-5, description="oil inertance"))
    g.add(R(f"{name}.R", flow=call(linear_flow, "e", f"p:{name}.R"),
            effort=call(linear_effort, "f", f"p:{name}.R"), description="laminar loss"))
    g.connect(up, f"{name}.C")
    g.connect(up, line)
    g.connect(line, f"{name}.I")
    g.connect(line, f"{name}.R")

    def derive(p: Mapping[str, float]) -> dict[str, float]:
        r, c, i = hose_coefficients(p[f"{name}.d"], p[f"{name}.L"], p["fluid.mu"],
                                    p["fluid.rho"], p["fluid.beta"])
        return {f"{name}.R": r, f"{name}.C": c, f"{name}.I": i}

    return Fragment(name, {"up": up, "line": line}, derive)
