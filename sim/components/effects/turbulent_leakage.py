"""Turbulent leakage ∝ √Δp through a worn gap: piston, valve spool, pump slip.

Bond-graph change: an R (flow out) across the two 0-junctions of the gap, through a new
1-junction (or straight to a 0-junction when the other side is the tank)::

    0[high] ── 1[gap] ── 0[low]          Q_t = K_t·sgn(Δp)·√|Δp|
                 │
               R(Q_t)

A worn clearance with a short land behaves as an orifice: the flow grows with √Δp
instead of Δp (Merritt, *Hydraulic Control Systems*, 1967, eq. 3-5; Ivantysyn &
Ivantysynova, *Hydrostatic Pumps and Motors*, 2001, §8.1 for pump slip).  ``K_t = C_d·A·√(2/ρ)``
[m³/(s·Pa^0.5)].  Three library entries use this module at three places.
"""

from __future__ import annotations

from collections.abc import Mapping

from sim.bondgraph import BondGraph, call
from sim.bondgraph.laws import law
from sim.components.effects.base import (
    PUMP_CIRCUITS,
    Arr,
    EffectEntry,
    leak_across,
    leak_to_tank,
    signed_sqrt,
    signed_sqrt_array,
)
from sim.params import Param

__all__ = ["PARAMETERS", "build_across", "build_to_tank", "entries", "turbulent_flow"]

PARAMETERS: tuple[Param, ...] = (
    Param("K_t", "m^3/(s*Pa^0.5)", 0.0, "effect strength, fitted (0 = off)",
          "orifice coefficient C_d·A·√(2/ρ) of the worn gap", lower=0.0, upper=1e-4,
          lower_inclusive=True),
    Param("p_t", "Pa", 1.0e4, "chosen: laminar core below 0.1 bar keeps the Jacobian finite",
          "transition pressure of the regularised √", lower=1.0, upper=1e6),
)


@law
def turbulent_flow(dp: float, K_t: float, p_t: float) -> float:
    """Q = K_t·sgn(Δp)·√|Δp| [m³/s], regularised below ``p_t`` (Merritt 1967, eq. 3-5)."""
    return K_t * signed_sqrt(dp, p_t)


def build_across(g: BondGraph, name: str, high: str, low: str,
                 values: Mapping[str, float] | None = None) -> None:
    """Add the √Δp path from 0-junction ``high`` to 0-junction ``low``."""
    leak_across(g, name, high, low, PARAMETERS, values,
                call(turbulent_flow, "e", f"p:{name}.K_t", f"p:{name}.p_t"),
                "Q = K_t·sgn(Δp)·√|Δp|")


def build_to_tank(g: BondGraph, name: str, high: str,
                  values: Mapping[str, float] | None = None) -> None:
    """Add the √P path from 0-junction ``high`` to the tank (pressure 0)."""
    leak_to_tank(g, name, high, PARAMETERS, values,
                 call(turbulent_flow, "e", f"p:{name}.K_t", f"p:{name}.p_t"),
                 "Q = K_t·sgn(P)·√|P|")


def _piston(s: Mapping[str, Arr]) -> Arr:
    return signed_sqrt_array(s["P1"] - s["P2"], 1e4)


def _pump(s: Mapping[str, Arr]) -> Arr:
    return signed_sqrt_array(s["P_pump"], 1e4)


def _spool(s: Mapping[str, Arr]) -> Arr:
    # the path runs from port P to port T, held at PRvt (paper 002 eq. 24)
    return signed_sqrt_array(s["P_valve_P"] - s.get("PRvt", 0.0), 1e4)


_REF = "Merritt, Hydraulic Control Systems (1967), eq. 3-5"


def entries() -> dict[str, tuple[EffectEntry, str, str | None]]:
    """Library entries of this module: name → (entry, high junction, low junction or None)."""
    return {
        "turbulent_piston_leakage": (EffectEntry(
            "turbulent_piston_leakage",
            "worn piston seal leaking as an orifice: flow ∝ √(P1 − P2) on top of the laminar gap",
            _REF, "pump-valve-cylinder", "chamber_flow", "K_t", "sgn(P1 − P2)·√|P1 − P2|",
            _piston, 1.0, (0.0, 5e-7)), "cylinder.c1", "cylinder.c2"),
        "turbulent_spool_leakage": (EffectEntry(
            "turbulent_spool_leakage",
            "worn 4/2 spool lands leaking P → T as an orifice: flow ∝ √(P_valve − P_T)",
            _REF, "pump-valve-cylinder", "valve_flow", "K_t", "√(P_valve_P − PRvt)",
            _spool, 1.0, (0.0, 5e-7)), "valve.P", "valve.T"),
        "turbulent_pump_slip": (EffectEntry(
            "turbulent_pump_slip",
            "pump slip through short worn gaps (tooth tips, side plates) ∝ √P",
            "Ivantysyn & Ivantysynova, Hydrostatic Pumps and Motors (2001), §8.1",
            "pump-valve-cylinder", "pump_flow", "K_t", "√P_pump", _pump, 1.0, (0.0, 5e-7),
            also=PUMP_CIRCUITS),
            "pump.out", None),
    }
