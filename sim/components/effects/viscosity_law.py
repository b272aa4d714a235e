"""Wrong viscosity–temperature law: the oil thins (or thickens) with temperature faster
than the stated law says.

The rig's oil follows the Walther law of ASTM D341 through two data-sheet points
(:mod:`sim.fluid`).  A different oil, an aged or sheared oil, or a wrong data sheet changes
the slope of μ(T); about the reference temperature the error is, to first order, an
exponential factor (Reynolds' viscosity law μ ∝ exp(−λ·T): O. Reynolds, *Phil. Trans. R.
Soc.* 177, 1886, 157-234; Merritt, *Hydraulic Control Systems*, 1967, ch. 2)::

    μ_true(T) = μ_stated(T) · exp(−λ·(T − T_ref))

λ [1/K] is the slope error (λ > 0: the true oil thins faster), ``T_ref`` the temperature
at which the stated law is right (the data sheet's 40 °C point).  λ = 0 (the default)
is the stated law exactly.  The catalogue expects λ > 0: a lower viscosity index than
stated — the shear-down of the VI improver of a multigrade hydraulic oil (ISO 11158
HV/HVLP, DIN 51524-3), or a top-up with a lower-VI oil — makes the oil thinner than
stated when hot; a higher VI than stated is not a fault.  The one-sided sign is also what
keeps the entry apart from the turbulent piston leak on a design whose temperature rises
with load (the column of a λ < 0 mimics √Δp's there).

Bond-graph change: none to the junction structure — every viscous element reads the one
parameter ``fluid.mu`` (the piston and spool laminar gaps, paper 002 eqs. 23 and 36; the
hoses' Hagen-Poiseuille resistance; the Couette drag), and the effect rescales it at the
oil temperature of the operating condition (:meth:`sim.rigs.assembly.Rig.values` applies
:func:`fluid_values` before the components derive their coefficients).  The R elements
are unchanged in form, so every one of them still only dissipates.

Signature in the chamber-2 flow balance: the piston's laminar leak ``G·(P1 − P2)/μ``
(``G = π·D·c³/(12·L)``, eq. 36) becomes ``G·(P1 − P2)/μ·exp(λ(T − T_ref))``; to first
order the excess is ``λ·(T − T_ref)·G·(P1 − P2)/μ``, a column that records at different
oil temperatures split from the re-fitted clearance ``(P1 − P2)/μ``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph
from sim.components.base import declare
from sim.components.effects.base import Arr, EffectEntry
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build", "fluid_values", "viscosity_factor"]

NAME = "viscosity_law"

PARAMETERS: tuple[Param, ...] = (
    Param("lam", "1/K", 0.0, "effect strength, fitted (0 = off)",
          "slope error λ of ln μ(T): μ_true = μ_stated·exp(−λ(T − T_ref))", lower=-0.1,
          upper=0.1, lower_inclusive=True),
    Param("T_ref", "degC", 40.0, "ISO 3448 reference temperature (the data sheet's 40 °C "
          "point, where the stated law is right)", "temperature at which the stated law holds",
          lower=-60.0, upper=200.0),
)


def viscosity_factor(T: float, lam: float, T_ref: float) -> float:
    """μ_true/μ_stated = exp(−λ·(T − T_ref)) [-] (Reynolds 1886, exponential law)."""
    return math.exp(-lam * (T - T_ref))


def fluid_values(values: Mapping[str, float], T: float, name: str = NAME) -> dict[str, float]:
    """The corrected ``fluid.mu`` [Pa·s] at oil temperature ``T`` [°C].

    ``values`` holds the stated ``fluid.mu`` and the effect's ``lam`` and ``T_ref`` when
    the rig file sets them (else their defaults).  With λ = 0 the stated value is kept
    (bit for bit).
    """
    lam = values.get(f"{name}.lam", PARAMETERS[0].default)
    if lam == 0.0:
        return {}
    t_ref = values.get(f"{name}.T_ref", PARAMETERS[1].default)
    return {"fluid.mu": values["fluid.mu"] * viscosity_factor(T, lam, t_ref)}


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Declare the effect's parameters (the change is to ``fluid.mu``, module docstring)."""
    declare(g, name, PARAMETERS, values)


def _regressor(s: Mapping[str, Arr]) -> Arr:
    t_ref = PARAMETERS[1].default
    return np.asarray((s["T"] - t_ref) * s["G_piston"] * (s["P1"] - s["P2"]) / s["mu"],
                      dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the oil's viscosity falls with temperature faster (or slower) than the "
                "stated law: every laminar leak and drag is off by exp(λ(T − T_ref))",
    reference="Reynolds, Phil. Trans. R. Soc. 177 (1886) 157 (exponential viscosity law); "
              "Merritt, Hydraulic Control Systems (1967), ch. 2; ASTM D341 (stated law)",
    circuit="pump-valve-cylinder", balance="chamber_flow", coefficient="lam",
    signature="(T − T_ref)·G·(P1 − P2)/μ", regressor=_regressor, sign=1.0,
    plausible=(0.0, 0.02))
