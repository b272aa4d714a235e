"""Check valve with a constant opening drop (paper 002 eqs. 53-54).

Bond-graph fragment: an R in effort-out causality on a line's 1-junction::

    1[line] ─ R_cv :  ΔP = PRcv   if Q > 0,   0 if Q ≤ 0

The paper's law is a step in Q; we smooth it over the small flow ``q_s`` as
``ΔP = PRcv · q⁺/√(q⁺² + q_s²)`` with ``q⁺ = max(Q, 0)``, which equals the step to within
0.5 % once ``Q > 10·q_s``.  Reverse flow passes without a drop, as in eq. 54.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from sim.bondgraph import BondGraph, R, call
from sim.bondgraph.laws import law
from sim.components.base import Fragment, declare
from sim.params import Param

__all__ = ["PARAMETERS", "build", "check_valve_drop"]

PARAMETERS: tuple[Param, ...] = (
    Param("PRcv", "Pa", 1.46e5, "chosen (seeds README: illegible): paper 002 §2.6 '.46e5' "
          "lost its leading digit, 1.46e5 or 3.46e5 Pa; 1.46e5 chosen (3.46e5 raises the spool "
          "leak 16 % at 2.1 kN against Table 3's closed row)", "opening drop",
          lower_inclusive=True),
    Param("q_s", "m^3/s", 1e-6, "chosen: smoothing flow (≈ 0.2 % of the pump flow)",
          "flow over which the drop builds up"),
)


@law
def check_valve_drop(q: float, PRcv: float, q_s: float) -> float:
    """Pressure drop [Pa] across the check valve at flow ``q`` [m³/s] (eqs. 53-54, smoothed)."""
    qp = max(q, 0.0)
    return PRcv * qp / math.sqrt(qp * qp + q_s * q_s)


def build(g: BondGraph, name: str, line: str, values: Mapping[str, float] | None = None) -> Fragment:
    """Add the check valve on the 1-junction ``line`` (forward = the line's bond direction)."""
    declare(g, name, PARAMETERS, values)
    g.add(R(name, effort=call(check_valve_drop, "f", f"p:{name}.PRcv", f"p:{name}.q_s"),
            description="eqs. 53-54"))
    g.connect(line, name)
    return Fragment(name, {"line": line})
