"""4/2 directional control valve with internal spool leakage (paper 002, eqs. 10-23).

Bond-graph fragment: 0-junctions at ports P, A, B, T; each path P→A, P→B, A→T, B→T is a
1-junction with a modulated resistance (the spool position ratio ``N`` modulates it),
and the spool-clearance leakage P→T is a 1-junction with ``R_lv``::

    0[P] ─ 1 ─ R_PA(N) ─ 0[A]        0[A] ─ 1 ─ R_AT(N) ─ 0[T]
    0[P] ─ 1 ─ R_PB(N) ─ 0[B]        0[B] ─ 1 ─ R_BT(N) ─ 0[T]
    0[P] ─ 1 ─ R_lv(cv) ─ 0[T]

``N`` = spool displacement / maximum displacement: +1 opens P→A and B→T, −1 opens P→B and
A→T (the paper's sign convention of eqs. 19-22).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from sim.bondgraph import BondGraph, One, R, Se, Zero, call
from sim.bondgraph.laws import constant, law
from sim.components.base import Fragment, declare
from sim.params import Param, Relation, at_most

__all__ = ["PARAMETERS", "RELATIONS", "build", "path_flow", "spool_leakage_flow"]

PARAMETERS: tuple[Param, ...] = (
    Param("K", "m^3/(s*Pa^0.5)", 5.0e-6, "chosen: paper 002 §2.6 K values illegible; Table 3 "
          "follows Qlv ∝ cv³ at an unchanged pressure, so the open paths must drop little "
          "(0.09 bar at the pump's 28 L/min)", "flow coefficient of each open path"),
    Param("p_tr", "Pa", 2.0e3, "chosen: laminar-turbulent transition pressure of the path law "
          "(keeps dQ/dΔp finite at ΔP = 0)", "transition pressure of the orifice law"),
    Param("cv", "m", 34e-6, "paper 002 Table 3 closed row / §2.6 ('4 μm' → 34 µm)",
          "radial clearance spool-body (equivalent clearance)"),
    Param("Dv", "m", 0.0125, "paper 002 §2.6 'Dv = 2.5 mm' read as 12.5 mm", "spool diameter Dv"),
    Param("Ls", "m", 4.739e-4, "chosen: sealing length of the spool lands at full shift, calibrated "
          "so the nominal rig leaks 8.6e-6 m³/s P→T at 2.1 kN (paper 002 Table 3 closed row); "
          "the copy's 'Lv = 5 mm' would need μ = 3.8e-3 Pa·s to leak that at 34 µm: the "
          "paper's valve data and Table 3 disagree, and only Dv/Ls enters eq. 23",
          "effective sealing length of eq. 23"),
    Param("W", "m", 0.02, "paper 002 §2.6 W = 0.02 m", "maximum spool displacement"),
    Param("N", "1", 1.0, "cycle: +1 working phase (P→A, B→T), −1 return phase",
          "spool position ratio Xi/W", lower=-1.0, upper=1.0, lower_inclusive=True),
    Param("PRvt", "Pa", 1.0e5, "paper 002 §2.6 'PR = 0.e6 Pa PRvt' read as 0.1e6 Pa (eq. 24)",
          "pressure of the T port: drop from T to tank", lower_inclusive=True),
)

#: Geometry: the radial clearance less than the spool's radius.
RELATIONS: tuple[Relation, ...] = (
    Relation("cv", "the radial clearance must be less than the spool's radius",
             lambda p: p["cv"] < 0.5 * p["Dv"]),
    at_most("Dv", 0.5, "m", "the largest cartridge valves' spools are ~0.1 m"),
    at_most("cv", 2e-3, "m", "60× the paper-002 spool's 34 µm"),
    at_most("Ls", 0.5, "m", "spool lands are millimetres long"),
)


@law
def path_flow(dp: float, K: float, N: float, direction: float, p_tr: float) -> float:
    """Flow through one open path, Q = K·N·√ΔP (paper 002 eqs. 19-22).

    Parameters
    ----------
    dp
        Pressure drop along the path, upstream − downstream [Pa].
    K
        Flow coefficient [m³/(s·Pa^0.5)].
    N
        Spool position ratio N = Xi/W, −1 to 1 [-].
    direction
        +1 for the paths that N > 0 opens (P→A, B→T), −1 for the others (P→B, A→T);
        the path's opening is ``max(direction·N, 0)`` (eqs. 19-22: closed paths carry
        no flow).
    p_tr
        Transition pressure [Pa]: below it the law becomes linear (laminar) so the flow
        is a smooth odd function of ΔP, ``K·N·ΔP/(ΔP² + p_tr²)^¼``.

    Returns
    -------
    float
        Flow [m³/s] in the direction of ``dp``.
    """
    opening = direction * N
    if opening <= 0.0:
        return 0.0
    return K * opening * dp / (dp * dp + p_tr * p_tr) ** 0.25


@law
def spool_leakage_flow(dp: float, cv: float, Dv: float, Ls: float, mu: float) -> float:
    """Internal leakage P→T through the spool clearance (paper 002 eq. 23).

    Laminar flow in a concentric annulus, ``Qlv = π·Dv·cv³·ΔP / (12·μ·Ls)``.  The copy of
    eq. 23 lets the sealing length depend on the spool position (W, Xi); in the cycle the
    spool is always fully shifted, so ``Ls`` is the land overlap at full shift, a single
    calibrated length (see the rig file).

    Parameters
    ----------
    dp
        P_P − P_T [Pa].
    cv
        Radial clearance [m].
    Dv
        Spool diameter [m].
    Ls
        Sealing length [m].
    mu
        Dynamic viscosity [Pa·s].
    """
    return math.pi * Dv * cv**3 * dp / (12.0 * mu * Ls)


_PATHS = (("PA", "P", "A", 1.0), ("PB", "P", "B", -1.0), ("AT", "A", "T", -1.0),
          ("BT", "B", "T", 1.0))


def build(g: BondGraph, name: str = "valve", values: Mapping[str, float] | None = None,
          mu: str = "p:fluid.mu") -> Fragment:
    """Add the 4/2 valve; ports ``P``, ``A``, ``B``, ``T`` are its 0-junctions.

    Port T is held at ``PRvt`` above tank by an effort source (eq. 24); ports P, A and B
    take their pressure from the volumes connected to them.
    """
    declare(g, name, PARAMETERS, values)
    ports = {k: f"{name}.{k}" for k in "PABT"}
    for node in ports.values():
        g.add(Zero(node))
    for path, a, b, direction in _PATHS:
        j = f"{name}.{path}"
        g.add(One(j))
        g.add(R(f"{name}.R{path}", flow=call(path_flow, "e", f"p:{name}.K", f"p:{name}.N",
                                             repr(direction), f"p:{name}.p_tr"),
                description=f"path {a}→{b}, eqs. 19-22"))
        g.connect(ports[a], j)
        g.connect(j, f"{name}.R{path}")
        g.connect(j, ports[b])
    leak = f"{name}.PT"
    g.add(One(leak, description="internal leakage P→T"))
    g.add(R(f"{name}.Rlv", flow=call(spool_leakage_flow, "e", f"p:{name}.cv", f"p:{name}.Dv",
                                     f"p:{name}.Ls", mu), description="eq. 23"))
    g.connect(ports["P"], leak)
    g.connect(leak, f"{name}.Rlv")
    g.connect(leak, ports["T"])
    g.add(Se(f"{name}.tank", constant, f"p:{name}.PRvt", description="P_T = PRvt (eq. 24)"))
    g.connect(f"{name}.tank", ports["T"])
    g.output("P_valve_P", f"effort:{ports['P']}", "Pa", "pressure at valve port P")
    g.output("Q_valve_leak", f"flow:{leak}", "m^3/s", "valve internal leakage P→T")
    return Fragment(name, ports)
