"""Pressure-dependent clearance: the gap opens as the pressure deforms its walls.

Bond-graph change: an R (flow out) across the gap's 0-junctions, through a new 1-junction
(or straight to the tank for the pump)::

    0[high] ── 1[gap] ── 0[low]          Q_c = k_c·Δp·|Δp|/μ(T)
                 │
               R(Q_c)

A laminar gap whose height grows linearly with pressure, h = h0(1 + εΔp), leaks
π·D·h³·Δp/(12·μ·L); to first order in ε the excess over the rigid gap is
3ε·(π·D·h0³/(12·L))·Δp²/μ (Ivantysyn & Ivantysynova, *Hydrostatic Pumps and Motors*, 2001,
§8.3, elastic deformation of gaps).  ``k_c`` [m³/Pa] lumps 3ε·πDh0³/(12L).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, call
from sim.bondgraph.laws import law
from sim.components.effects.base import (
    PUMP_CIRCUITS,
    Arr,
    EffectEntry,
    leak_across,
    leak_to_tank,
)
from sim.params import Param

__all__ = ["PARAMETERS", "build_across", "build_to_tank", "clearance_flow", "entries"]

PARAMETERS: tuple[Param, ...] = (
    Param("k_c", "m^3/Pa", 0.0, "effect strength, fitted (0 = off)",
          "excess leakage coefficient of the deforming gap 3ε·πDh0³/(12L)", lower=0.0,
          upper=1e-15, lower_inclusive=True),
)


@law
def clearance_flow(dp: float, k_c: float, mu: float) -> float:
    """Q = k_c·Δp·|Δp|/μ [m³/s] (Ivantysyn & Ivantysynova 2001, §8.3, first order in ε)."""
    return k_c * dp * abs(dp) / mu


def build_across(g: BondGraph, name: str, high: str, low: str,
                 values: Mapping[str, float] | None = None) -> None:
    """Add the deforming-gap path from 0-junction ``high`` to 0-junction ``low``."""
    leak_across(g, name, high, low, PARAMETERS, values,
                call(clearance_flow, "e", f"p:{name}.k_c", "p:fluid.mu"), "Q = k_c·Δp·|Δp|/μ")


def build_to_tank(g: BondGraph, name: str, high: str,
                  values: Mapping[str, float] | None = None) -> None:
    """Add the deforming-gap path from 0-junction ``high`` to the tank."""
    leak_to_tank(g, name, high, PARAMETERS, values,
                 call(clearance_flow, "e", f"p:{name}.k_c", "p:fluid.mu"), "Q = k_c·P·|P|/μ")


def _piston(s: Mapping[str, Arr]) -> Arr:
    dp = s["P1"] - s["P2"]
    return np.asarray(dp * np.abs(dp) / s["mu"], dtype=float)


def _pump(s: Mapping[str, Arr]) -> Arr:
    p = s["P_pump"]
    return np.asarray(p * np.abs(p) / s["mu"], dtype=float)


_REF = "Ivantysyn & Ivantysynova, Hydrostatic Pumps and Motors (2001), §8.3"


def entries() -> dict[str, tuple[EffectEntry, str, str | None]]:
    """Library entries of this module: name → (entry, high junction, low junction or None)."""
    return {
        "piston_clearance_pressure": (EffectEntry(
            "piston_clearance_pressure",
            "piston-bore gap widening under pressure: leakage grows with Δp²/μ",
            _REF, "pump-valve-cylinder", "chamber_flow", "k_c", "(P1 − P2)·|P1 − P2|/μ",
            _piston, 1.0, (0.0, 1e-17)), "cylinder.c1", "cylinder.c2"),
        "pump_clearance_pressure": (EffectEntry(
            "pump_clearance_pressure",
            "pump side plates and housing deflecting under pressure: slip grows with P²/μ",
            _REF, "pump-valve-cylinder", "pump_flow", "k_c", "P·|P|/μ", _pump, 1.0,
            (0.0, 1e-17), also=PUMP_CIRCUITS), "pump.out", None),
    }
