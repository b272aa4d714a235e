"""Entrained air: the oil in the cylinder chambers is softer at low pressure.

Undissolved air bubbles carried in the oil make the effective bulk modulus fall steeply
as the pressure drops.  With a free-air volume fraction α0 at atmospheric pressure p_a,
compressed polytropically (p·V_g^n = const), the gas volume in a chamber of oil volume V
is ``V_g = α0·V·(p_a/p_abs)^(1/n)`` and its compliance ``−dV_g/dp = V_g/(n·p_abs)``; in
series with the liquid (Merritt, *Hydraulic Control Systems*, 1967, ch. 2, effective bulk
modulus: 1/β_e = 1/β_l + (V_g/V_t)/β_g with β_g = n·p; Manring, *Hydraulic Control
Systems*, 2005, ch. 2, entrained air)::

    C(p, x) = V(x)/β + α0·V(x)·(p_a/p_abs)^(1/n) / (n·p_abs),     p_abs = p + p_a

The pressures of the model are gauge (tank = 0); ``p_abs`` is floored at p_a/10 so that a
simulated excursion below vacuum keeps the capacitance finite.  α0 [-] is the strength;
α0 = 0 (the default) is paper 002 eqs. 33-34 exactly.

Bond-graph change: the two chamber C elements of the cylinder (``cylinder.C1``,
``cylinder.C2``) keep their place and integral causality; their capacitance law becomes
:func:`air_capacitance`, reading the element's own effort (its pressure state).  A C
stores and returns energy; the pressure-dependent (tangent) capacitance stays positive.

Signature: only where a chamber pressure changes.  In the chamber-2 flow balance the
compressibility term ``−V2·Ṗ2/β`` gains ``−α0·V2·(p_a/p_abs)^(1/n)/(n·p_abs)·Ṗ2``: a
column that differs from the base ``V2·Ṗ2`` by the factor that grows as P2 falls — the
pressure build-up and decay after each valve switch.  In steady motion (Ṗ = 0) there is
none.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, LawCall
from sim.bondgraph.laws import law
from sim.components.base import declare
from sim.components.cylinder import chamber_capacitance
from sim.components.effects.base import Arr, EffectEntry
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "air_capacitance", "air_compliance_factor", "build"]

NAME = "entrained_air"
#: the chamber capacitances the effect changes (paper-002 circuit)
CHAMBERS = ("cylinder.C1", "cylinder.C2")

PARAMETERS: tuple[Param, ...] = (
    Param("alpha", "1", 0.0, "effect strength, fitted (0 = off)",
          "free-air volume fraction of the oil at atmospheric pressure", lower=0.0,
          upper=0.2, lower_inclusive=True),
    Param("n", "1", 1.4, "chosen: adiabatic air (compression within a valve switching time "
          "of ~0.1 s is too fast for heat exchange); Merritt 1967 ch. 2",
          "polytropic exponent of the air", lower=1.0, upper=1.67, lower_inclusive=True),
    Param("p_a", "Pa", 101325.0, "standard atmosphere (ISO 2533)",
          "atmospheric pressure (the gauge zero of the model)"),
)


@law
def air_compliance_factor(p: float, n: float, p_a: float) -> float:
    """(p_a/p_abs)^(1/n)/(n·p_abs) [1/Pa]: air compliance per unit free-air volume.

    ``p`` is the gauge pressure [Pa]; ``p_abs = p + p_a`` floored at ``p_a/10``.
    """
    p_abs = max(p + p_a, 0.1 * p_a)
    return (p_a / p_abs) ** (1.0 / n) / (n * p_abs)


@law
def air_capacitance(V0: float, A: float, x: float, x_ref: float, side: float, beta: float,
                    p: float, alpha: float, n: float, p_a: float) -> float:
    """C = V/β + α0·V·(p_a/p_abs)^(1/n)/(n·p_abs) [m³/Pa] (module docstring).

    ``V = V0 + A·max(x_ref + side·x, 0)`` as in paper 002 eqs. 33-34; α0 = 0 gives
    :func:`sim.components.cylinder.chamber_capacitance` exactly.
    """
    c = chamber_capacitance(V0, A, x, x_ref, side, beta)
    if alpha == 0.0:
        return c
    vol = V0 + A * max(x_ref + side * x, 0.0)
    return c + alpha * vol * air_compliance_factor(p, n, p_a)


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Give the chamber capacitances the entrained-air law (module docstring)."""
    declare(g, name, PARAMETERS, values)
    for chamber in CHAMBERS:
        el = g.elements[chamber]
        assert el.law is not None and el.law.func is chamber_capacitance
        el.law = LawCall(air_capacitance, (*el.law.args, "e", f"p:{name}.alpha",
                                           f"p:{name}.n", f"p:{name}.p_a"))
        el.description += " + entrained air α0·V·(p_a/p_abs)^(1/n)/(n·p_abs)"


def _regressor(s: Mapping[str, Arr]) -> Arr:
    n, p_a = PARAMETERS[1].default, PARAMETERS[2].default
    p_abs = np.maximum(s["P2"] + p_a, 0.1 * p_a)
    x = s["x"] if "x" in s else np.zeros_like(s["P2"])
    vol2 = s["V02"] + s["A2"] * np.maximum(s["stroke"] - x, 0.0)
    return np.asarray(-vol2 * (p_a / p_abs) ** (1.0 / n) / (n * p_abs) * s["dP2"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="air bubbles in the oil: the chambers' bulk modulus falls at low pressure, "
                "so pressure builds up and decays slower after a valve switch",
    reference="Merritt, Hydraulic Control Systems (1967), ch. 2 (effective bulk modulus with "
              "entrained air); Manring, Hydraulic Control Systems (2005), ch. 2",
    circuit="pump-valve-cylinder", balance="chamber_flow", coefficient="alpha",
    signature="−V2·(p_a/p_abs2)^(1/n)/(n·p_abs2)·Ṗ2", regressor=_regressor, sign=1.0,
    plausible=(0.0, 0.02), window="build-up")
