"""Relief-valve override growing with flow: the valve's pressure–flow line is not straight.

Paper 002 eq. 6 gives the relief valve a straight characteristic above its setting,
``P − Pset = Rrv·Q`` (a constant override slope; a drift of that slope is a base-parameter
error, ``relief.Rrv``).  In a direct-acting poppet valve the steady flow force of the jet
leaving the seat pushes the poppet closed, so the pressure needed to pass a flow grows
faster than linearly: the jet momentum flux ρ·Q²/(C_c·A) adds a force ∝ Q² at a given
opening (Merritt, *Hydraulic Control Systems*, 1967, ch. 5, steady-state flow forces;
Manring, *Hydraulic Control Systems*, 2005, ch. 4, pressure-relief valves: the
override pressure).  Lumped over the valve's operating range::

    P − Pset = Rrv·Q + k_ov·Q²        ⇒  Q = 2·(P − Pset) / (Rrv + √(Rrv² + 4·k_ov·(P − Pset)))

for ``P > Pset`` (closed below; the seat leak ``Gseat·P`` is unchanged).  ``k_ov``
[Pa·s²/m⁶] is the strength; k_ov = 0 (the default) is eq. 6 exactly.  At the paper-002
pump's full flow (28 L/min) eq. 6 overrides by 11.7 bar; k_ov = 4.6e12 adds 10 bar more
(the plausible range's top).

Bond-graph change: the relief R on the pump outlet 0-junction keeps its place and its
flow-out causality; its constitutive law becomes :func:`override_flow`.  Q ≥ 0 whenever
P ≥ 0, so it only dissipates.

Signature: only while the relief passes flow (``P_pump > Pset``): to first order in
k_ov the relief passes ``(P − Pset)/Rrv − k_ov·(P − Pset)²/Rrv³``, so the pump-outlet flow
balance over those samples (``relief_flow``: ω·Vp − Q_B = P/Rlp + Cp·Ṗ + (P − Pset)/Rrv
+ k_ov·column) gains the column ``−(P − Pset)²/Rrv³``.  The paper-002 cycle
(:func:`sim.cycle.run_cycle`) ends each phase when the piston reaches its stop, so the
relief never opens (at most 45 bar of the 70 bar setting over the discrepancy study's
loads) and the effect leaves no trace at all; :mod:`diagnostics.discrepancy.balances`
therefore has no ``relief_flow`` balance yet — it needs a cycle that dwells at the stop.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, call
from sim.bondgraph.laws import law
from sim.components.base import declare
from sim.components.effects.base import Arr, EffectEntry
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build", "override_flow"]

NAME = "relief_override"
#: the relief valve's R element (and parameter prefix) in the paper-002 circuit
RELIEF = "relief"

PARAMETERS: tuple[Param, ...] = (
    Param("k_ov", "Pa*s^2/m^6", 0.0, "effect strength, fitted (0 = off)",
          "quadratic override coefficient of the relief characteristic", lower=0.0,
          upper=1e15, lower_inclusive=True),
)


@law
def override_flow(p: float, Pset: float, Rrv: float, Gseat: float, k_ov: float) -> float:
    """Relief flow [m³/s] with the override P − Pset = Rrv·Q + k_ov·Q² (module docstring).

    ``k_ov = 0`` is paper 002 eq. 6 exactly; the root is written so that it stays
    accurate for small ``k_ov``.
    """
    q = Gseat * p
    if p > Pset:
        d = p - Pset
        if k_ov == 0.0:
            q += d / Rrv
        else:
            q += 2.0 * d / (Rrv + math.sqrt(Rrv * Rrv + 4.0 * k_ov * d))
    return q


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Give the relief R the override law (module docstring)."""
    declare(g, name, PARAMETERS, values)
    el = g.elements[RELIEF]
    el.flow_law = call(override_flow, "e", f"p:{RELIEF}.Pset", f"p:{RELIEF}.Rrv",
                       f"p:{RELIEF}.Gseat", f"p:{name}.k_ov")
    el.description = "eq. 6 with the override P − Pset = Rrv·Q + k_ov·Q²"


def _regressor(s: Mapping[str, Arr]) -> Arr:
    # the override takes k_ov·d²/Rrv³ from the relief flow, so the pump delivers that
    # much more past the outlet junction: −column in ω·Vp − Q_B
    d = np.maximum(s["P_pump"] - s["Pset"], 0.0)
    return np.asarray(-d * d / s["Rrv"] ** 3, dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the relief valve needs more pressure to pass more flow than its straight "
                "eq.-6 line (flow force on the poppet): override ∝ Q²",
    reference="Merritt, Hydraulic Control Systems (1967), ch. 5 (steady flow forces); "
              "Manring, Hydraulic Control Systems (2005), ch. 4 (relief-valve override)",
    circuit="pump-valve-cylinder", balance="relief_flow", coefficient="k_ov",
    signature="−(P_pump − Pset)²/Rrv³ while the relief passes flow", regressor=_regressor,
    sign=1.0, plausible=(0.0, 1e13))
