"""External gear pump as a bond-graph fragment (paper 000 §4, Figure 7; eqs. 6 and 16).

Figure 7 of paper 000, as its text describes it, becomes::

    MSf ENGINE(ω) ─ 1[ω] ─ MTF PUMP(D) ─ 0[p_core] ─ 1[Q] ─ 0[p_out] ─ port "out"
                    │ R VISC  R COUL       │ C COMPRPUMP   │ I INERTPUMP
                                           │ R LAMIN        │ R RoutPUMP
                                           │ R TURB
                                           │ R COMP

* **MSf ENGINE** imposes the shaft speed ω (the diesel engine; constant in a test, paper
  000 §3.2.2).  **MTF PUMP** is the ideal pump: flow ``D·ω`` and torque ``D·p_core``
  (eq. 13) with the derived capacity D [m³/rad] as modulus.
* The first 0-junction sets the volumetric efficiency.  The paper draws the three losses of
  eq. 6 as modulated flow sources; here each is a modulated R (its flow is a function of
  the junction pressure and of ω, and it absorbs power, which makes the power balance
  explicit): **LAMIN** ``Cs·Δp·D/μ`` (eq. 4), **TURB** ``Cst·√(2Δp·D^(4/3)/ρ)`` (eqs. 5, 9),
  **COMP** ``Δp·D·ω/β_ef``.  **C COMPRPUMP** is the compliance ``V_out/β_ef`` of the oil in
  the outlet chamber and passage.
* The first 1-junction sets the mechanical efficiency: **VISC** ``Cv·μ·ω·D`` (eq. 14) and
  **COUL** ``Cf·Δp·D`` (eq. 15) as R elements with torque laws.  The shaft torque is the
  effort of the MSf bond: ``T = Δp·D + Cv·μ·ω·D + Cf·Δp·D`` (eq. 16, pump sign convention,
  see :mod:`sim.components.gear_pump`).  Pump inertia is neglected (paper 000 §4).
* **INERTPUMP** and **RoutPUMP**: inertance ``ρ·L/A`` and laminar resistance
  ``128·μ·L/(π·d⁴)`` of the outlet passage (:func:`sim.components.hose.hose_coefficients`).

Conventions: Δp is the gauge pressure of the core junction (the inlet is at tank pressure,
0 bar gauge, as in :mod:`diagnostics.slip`); the losses act at the core pressure, which at
steady state exceeds the port pressure by ``R_out·Q`` (≈ 0.01 bar at 20 L/min).  The
coefficients C(Δp, ω) are four polynomial surfaces held as 4 × 16 graph parameters
(``NAME.Cs.c00`` … ``NAME.Cf.c33`` with their scales ``p_ref``, ``omega_ref``); the oil
viscosity is the table ``NAME.mu`` (a signal of time; a constant for a steady point).  The
graph needs the fluid parameters ``fluid.mu`` (outlet-passage resistance only) declared by
the caller, as :mod:`sim.components.hose` does.

The documented gaps of paper 000 §5 (side-plate lag, hysteresis) are not part of the
fragment: they are entries of the effect library (:mod:`sim.components.effects`,
``side_plate_lag`` and ``slip_hysteresis``) that add their elements at ``NAME.core``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from sim.bondgraph import MTF, BondGraph, C, I, MSf, One, R, Zero, call
from sim.bondgraph.laws import constant, linear_effort, linear_flow, quotient
from sim.components import gear_pump_laws as laws
from sim.components.base import Fragment, declare
from sim.components.gear_pump import PARAMETERS as LOSS_PARAMETERS
from sim.components.gear_pump import CoefficientSurface, GearPump
from sim.components.gear_pump_map import stand_in_pump
from sim.components.hose import hose_coefficients
from sim.errors import ParameterError
from sim.params import Param

__all__ = ["COEFFICIENTS", "PARAMETERS", "build", "pump_values",
           "surface_values"]

RPM = 2.0 * math.pi / 60.0

#: The four loss-coefficient surfaces, in the order the fragment declares them.
COEFFICIENTS = ("Cs", "Cst", "Cv", "Cf")

PARAMETERS: tuple[Param, ...] = (
    Param("speed", "rad/s", 1467 * RPM, "paper 000 §5: field test speed 1467 rpm",
          "shaft speed ω imposed by the engine (MSf ENGINE)"),
    *LOSS_PARAMETERS,
    Param("V_out", "m^3", 20e-6, "chosen: outlet chamber and passage of a 14.7 cm³/rev pump "
          "(paper 000 gives no value)", "oil volume of the outlet passage (C COMPRPUMP)"),
    Param("d_out", "m", 0.015, "chosen: outlet port bore (3/4-inch flange port)",
          "outlet passage bore"),
    Param("L_out", "m", 0.06, "chosen: passage length through the pump body",
          "outlet passage length"),
    Param("dp_s", "Pa", 100.0, "chosen: regularisation of √Δp (6e-10 relative at 20 bar)",
          "pressure scale of the smooth root in the turbulent slip"),
    Param("omega_s", "rad/s", 1e-3, "chosen: sgn(ω) = tanh(ω/ω_s) is 1.0 above 0.02 rad/s",
          "speed scale of the Coulomb torque's sign"),
)

def surface_values(surface: CoefficientSurface) -> list[float]:
    """The 16 coefficients ``c00 … c33`` of a surface of degree ≤ 3 in Δp and in ω [-].

    Raises
    ------
    ParameterError
        A degree above 3 (the compiled law evaluates bicubic surfaces).
    """
    dp_deg, w_deg = surface.degrees
    if dp_deg > 3 or w_deg > 3:
        raise ParameterError(f"surface degree {surface.degrees} exceeds (3, 3)", field="coef")
    c = [[0.0] * 4 for _ in range(4)]
    for i in range(dp_deg + 1):
        for j in range(w_deg + 1):
            c[i][j] = float(surface.coef[i, j])
    return [c[i][j] for i in range(4) for j in range(4)]


def pump_values(pump: GearPump, name: str = "pump") -> dict[str, float]:
    """Graph parameter values (``name.D``, ``name.Cs.c00`` …) that describe ``pump``.

    A compiled fragment is re-parameterised with these overrides (a worn pump, a re-fitted
    map) without compiling again.
    """
    out = {f"{name}.D": pump.D, f"{name}.rho": pump.rho, f"{name}.beta_ef": pump.beta_ef}
    for k in COEFFICIENTS:
        surf: CoefficientSurface = getattr(pump, k)
        out[f"{name}.{k}.p_ref"] = surf.p_ref
        out[f"{name}.{k}.omega_ref"] = surf.omega_ref
        for idx, v in enumerate(surface_values(surf)):
            out[f"{name}.{k}.c{idx // 4}{idx % 4}"] = v
    return out


def _surface_refs(name: str, k: str) -> tuple[str, ...]:
    return (f"p:{name}.{k}.p_ref", f"p:{name}.{k}.omega_ref",
            *(f"p:{name}.{k}.c{i}{j}" for i in range(4) for j in range(4)))


def build(g: BondGraph, name: str = "pump", *, pump: GearPump | None = None,
          values: Mapping[str, float] | None = None, viscosity_points: int = 2) -> Fragment:
    """Add the gear pump of Figure 7 (module docstring) to ``g``.

    Parameters
    ----------
    g
        The graph; must already declare ``fluid.mu`` [Pa·s] (outlet passage resistance).
    name
        Prefix of the elements and parameters.
    pump
        Coefficient surfaces, D, ρ and β_ef (default: the stand-in map of
        :mod:`sim.components.gear_pump_map`, not bench data).
    values
        Overrides of :data:`PARAMETERS` by short name (``{"speed": 150.0}``).
    viscosity_points
        Size of the viscosity table ``NAME.mu`` (2 for a constant, the record length for a
        duty cycle).

    Returns
    -------
    Fragment
        Ports ``out`` (outlet 0-junction) and ``shaft`` (1-junction); ``derive`` recomputes
        the outlet-passage R and I from ``fluid.mu`` and the pump's parameters.
    """
    pm = pump if pump is not None else stand_in_pump()
    if "fluid.mu" not in g.parameters:
        raise ParameterError("declare fluid.mu before the gear pump", field="fluid.mu")
    declare(g, name, PARAMETERS, {"D": pm.D, "rho": pm.rho, "beta_ef": pm.beta_ef,
                                  **(values or {})})
    for key, value in pump_values(pm, name).items():
        _, coef, field = key.split(".") if key.count(".") == 2 else ("", "", "")
        if coef:
            unit = "Pa" if field == "p_ref" else "rad/s" if field == "omega_ref" else "1"
            g.parameter(key, value, unit, f"surface {coef}(Δp, ω), term {field}: "
                        f"{pm.note or 'given pump map'}")
    for k in ("R_out", "I_out"):
        g.parameter(f"{name}.{k}", 1.0, "Pa*s/m^3" if k == "R_out" else "kg/m^4",
                    "derived from d_out, L_out, the pump's ρ and fluid.mu")
    mu = g.table(f"{name}.mu", viscosity_points, value=pm.fluid.dynamic_viscosity(40.0),
                 unit="Pa*s", source="oil viscosity μ(θ(t)) from the temperature record")
    shaft, core, passage, out = (f"{name}.shaft", f"{name}.core", f"{name}.passage",
                                 f"{name}.out")
    P = f"p:{name}."
    w, dp = f"flow:{shaft}", "e"
    g.add(MSf(f"{name}.engine", constant, f"{P}speed", description="MSf ENGINE: shaft speed ω"))
    g.add(One(shaft, description="shaft speed ω: mechanical efficiency"))
    g.add(R(f"{name}.visc", effort=call(laws.viscous_torque, "f", f"effort:{core}", "t", mu,
                                        f"{P}D", *_surface_refs(name, "Cv")),
            description="MSe VISC: Tv = Cv·μ·ω·D (eq. 14)"))
    g.add(R(f"{name}.coul", effort=call(laws.load_torque, "f", f"effort:{core}", f"{P}D",
                                        f"{P}omega_s", *_surface_refs(name, "Cf")),
            description="MSe COUL: Tf = Cf·Δp·D (eq. 15)"))
    g.add(MTF(f"{name}.ideal", constant, f"{P}D", description="MTF PUMP: Q = D·ω, T = D·Δp"))
    g.add(Zero(core, description="pump core pressure: volumetric efficiency"))
    g.add(C(f"{name}.compr", quotient, f"{P}V_out", f"{P}beta_ef", scale=1e5,
            description="C COMPRPUMP: V_out/β_ef"))
    lam = call(laws.laminar_slip, dp, w, "t", mu, f"{P}D", *_surface_refs(name, "Cs"))
    turb = call(laws.turbulent_slip, dp, w, f"{P}rho", f"{P}D", f"{P}dp_s",
                *_surface_refs(name, "Cst"))
    g.add(R(f"{name}.lamin", flow=lam, description="MSf LAMIN: Qs = Cs·Δp·D/μ (eq. 4)"))
    g.add(R(f"{name}.turb", flow=turb, description="MSf TURB: Qst (eqs. 5, 9)"))
    g.add(R(f"{name}.comp", flow=call(laws.compression_loss, dp, w, f"{P}D", f"{P}beta_ef"),
            description="MSf COMP: Qc = Δp·D·ω/β_ef (eq. 6)"))
    g.add(One(passage, description="outlet passage flow = delivered flow Q"))
    g.add(I(f"{name}.inert", constant, f"{P}I_out", scale=1e-5, description="INERTPUMP"))
    g.add(R(f"{name}.rout", flow=call(linear_flow, "e", f"{P}R_out"),
            effort=call(linear_effort, "f", f"{P}R_out"), description="RoutPUMP"))
    g.add(Zero(out, description="pump outlet port pressure"))
    for src, dst, label in ((f"{name}.engine", shaft, f"{name}.shaft_in"),
                            (shaft, f"{name}.visc", f"{name}.visc"),
                            (shaft, f"{name}.coul", f"{name}.coul"),
                            (shaft, f"{name}.ideal", f"{name}.ideal_in"),
                            (f"{name}.ideal", core, f"{name}.ideal_out"),
                            (core, f"{name}.compr", ""),
                            (core, f"{name}.lamin", f"{name}.lamin"),
                            (core, f"{name}.turb", f"{name}.turb"),
                            (core, f"{name}.comp", f"{name}.comp"),
                            (core, passage, ""),
                            (passage, f"{name}.inert", ""),
                            (passage, f"{name}.rout", f"{name}.rout"),
                            (passage, out, "")):
        g.connect(src, dst, label)
    for oname, expr, unit, what in (
            ("Q", f"flow:{passage}", "m^3/s", "delivered flow at the outlet port"),
            ("p_core", f"effort:{core}", "Pa", "pressure at which the losses act"),
            ("p_out", f"effort:{out}", "Pa", "outlet port pressure"),
            ("torque", f"e:{name}.shaft_in", "N*m", "shaft torque (eq. 16)"),
            ("Q_ideal", f"f:{name}.ideal_out", "m^3/s", "geometric flow D·ω"),
            ("Q_s", f"f:{name}.lamin", "m^3/s", "laminar slip"),
            ("Q_st", f"f:{name}.turb", "m^3/s", "turbulent slip"),
            ("Q_c", f"f:{name}.comp", "m^3/s", "compressibility loss"),
            ("T_v", f"e:{name}.visc", "N*m", "viscous friction torque"),
            ("T_f", f"e:{name}.coul", "N*m", "load-dependent friction torque")):
        g.output(f"{name}.{oname}", expr, unit, what)

    def derive(p: Mapping[str, float]) -> dict[str, float]:
        r, _, inert = hose_coefficients(p[f"{name}.d_out"], p[f"{name}.L_out"], p["fluid.mu"],
                                        p[f"{name}.rho"], p[f"{name}.beta_ef"])
        return {f"{name}.R_out": r, f"{name}.I_out": inert}

    current = {k: v.value for k, v in g.parameters.items()}
    for k, v in derive(current).items():
        g.parameters[k].value = v
    return Fragment(name, {"out": out, "shaft": shaft}, derive,
                    [f"{name}.{o}" for o in ("Q", "p_core", "p_out", "torque")])
