"""Fixed-displacement pump with internal leakage, driven at constant speed (paper 002 eqs. 1-5).

Bond-graph fragment::

    Sf(ω) ─ 1[ω] ─ TF(Vp) ─ 0[Pp] ─ port_out
                             │ C(Cp)  R(Rlp)

The electric motor imposes the shaft speed ω (Sf, eq. 1); the TF with modulus ``Vp``
[m³/rad] turns it into the geometric flow ``Qp = ω·Vp`` (eq. 2); the outlet volume is the
capacitance ``Cp`` (eqs. 3-4) and the internal leakage to the case/tank is the linear
resistance ``Rlp``: ``Qlp = Pp/Rlp`` (eq. 5).  A worn pump has a smaller ``Rlp``.
"""

from __future__ import annotations

from collections.abc import Mapping

from sim.bondgraph import TF, BondGraph, C, R, Sf, Zero, call
from sim.bondgraph.laws import constant, linear_effort, linear_flow
from sim.components.base import Fragment, declare
from sim.params import Param, Relation, at_most

__all__ = ["PARAMETERS", "RELATIONS", "build"]

PARAMETERS: tuple[Param, ...] = (
    Param("speed", "rad/s", 1600 * 2 * 3.141592653589793 / 60, "paper 002 §2.6 ω = 1600 rpm "
          "(repaired '600 rpm')", "shaft speed ω"),
    Param("Vp", "m^3/rad", 1.75e-5 / (2 * 3.141592653589793), "paper 002 §2.6 Vp = 1.75e-5 "
          "m³/rev", "geometric displacement per radian"),
    Param("Cp", "m^3/Pa", 4.48e-13, "chosen: paper 002 §2.6 'Cp 2 m e = 4.48 Pa' keeps a 2 "
          "near the exponent (e-12: 6.7 L of oil at β = 1.5e9 Pa); e-13 (≈0.67 L: pump outlet "
          "and line to the valve) chosen as the plausible volume",
          "outlet capacitance"),
    Param("Rlp", "Pa*s/m^3", 6.0e11, "chosen (seeds README: illegible): paper 002 §2.6 '6e 2' "
          "reads 6e12 Pa·s/m³ or, in its conductance unit layout, 6e-12 m³/(s·Pa); 6e11 "
          "(volumetric efficiency 97.5 % at the 70 bar setting) lies between their 99.75 % "
          "and 91 % (sim/rigs/reference_002.yaml)", "internal leakage resistance"),
)

#: Plausibility: displacement and speed within what pumps are built with.
RELATIONS: tuple[Relation, ...] = (
    at_most("Vp", 1e-3, "m^3/rad", "6.3 L/rev; the largest hydrostatic pumps displace ~1 L/rev"),
    # 1450 "rad/s" (an rpm slip, 13,846 rpm) passed 2000 rad/s (a rig author's pass)
    at_most("speed", 1100.0, "rad/s", "10,500 rpm; the fastest hydraulic pumps, aircraft "
            "engine-driven ones, turn ~10,000 rpm"),
)


def build(g: BondGraph, name: str = "pump", values: Mapping[str, float] | None = None) -> Fragment:
    """Add the pump fragment (module docstring) to ``g``; port ``out`` is the outlet 0-junction."""
    declare(g, name, PARAMETERS, values)
    out = f"{name}.out"
    g.add(Sf(f"{name}.motor", constant, f"p:{name}.speed", description="shaft speed ω (eq. 1)"))
    g.add(TF(f"{name}.TF", constant, f"p:{name}.Vp", description="Qp = ω·Vp (eq. 2)"))
    g.add(Zero(out, description="pump outlet pressure Pp"))
    g.add(C(f"{name}.Cp", constant, f"p:{name}.Cp", scale=1e5, description="eqs. 3-4"))
    g.add(R(f"{name}.leak", flow=call(linear_flow, "e", f"p:{name}.Rlp"),
            effort=call(linear_effort, "f", f"p:{name}.Rlp"), description="Qlp = Pp/Rlp (eq. 5)"))
    g.connect(f"{name}.motor", f"{name}.TF", label=f"{name}.shaft")
    g.connect(f"{name}.TF", out, label=f"{name}.geometric")
    g.connect(out, f"{name}.Cp")
    g.connect(out, f"{name}.leak", label=f"{name}.leak")
    g.output("P_pump", f"effort:{out}", "Pa", "pump outlet pressure")
    g.output("Q_pump_leak", f"f:{name}.leak", "m^3/s", "pump internal leakage")
    g.output("T_pump", f"e:{name}.shaft", "N*m", "ideal shaft torque Vp·Pp")
    return Fragment(name, {"out": out})
