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

Signature: only while the relief passes flow (``P_pump > Pset``).  Written for the flow,
the law is exactly ``Q = (P − Pset)/Rrv − k_ov·Q²/Rrv``, so the pump-outlet flow balance
with the stated relief line subtracted (``relief_flow`` of
:mod:`diagnostics.discrepancy.balances`: ω·Vp − Q_B − (P − Pset)/Rrv = P/Rlp + Cp·Ṗ + …)
gains the column ``−Q²/Rrv``, Q the relief flow estimated from measured signals and the
stated pump, ``ω·Vp − Q_B − P/Rlp − Cp·Ṗ``.  A cycle whose phases end at the end stops
never opens the relief (at most 45 bar of the 70 bar setting over the discrepancy
study's loads): the effect shows only in records with a *dwell* at the stop
(:data:`diagnostics.discrepancy.synthetic.DWELLS`), at three relief flows or more, since
the balance re-fits the relief's setting and slope (constant and linear in Q) before an
override is named.
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
    # P − Pset = Rrv·Q + k_ov·Q² ⇔ Q = (P − Pset)/Rrv − k_ov·Q²/Rrv exactly: with the
    # stated relief line subtracted from the outlet balance the override leaves
    # −Q²/Rrv, Q the relief flow estimated from measured signals and the stated pump
    # (ω·Vp − Q_B − P/Rlp − Cp·Ṗ) while the relief passes flow
    opened = s["P_pump"] > s["Pset"]
    q = s["speed"] * s["Vp"] - s["Q_meter_B"] - s["P_pump"] / s["Rlp"] - s["Cp"] * s["dP_pump"]
    q = np.where(opened, np.maximum(q, 0.0), 0.0)
    return np.asarray(-q * q / s["Rrv"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the relief valve needs more pressure to pass more flow than its straight "
                "eq.-6 line (flow force on the poppet): override ∝ Q²",
    reference="Merritt, Hydraulic Control Systems (1967), ch. 5 (steady flow forces); "
              "Manring, Hydraulic Control Systems (2005), ch. 4 (relief-valve override)",
    circuit="pump-valve-cylinder", balance="relief_flow", coefficient="k_ov",
    signature="−Q_relief²/Rrv while the relief passes flow (Q_relief = ω·Vp − Q_B − P/Rlp "
              "− Cp·Ṗ)", regressor=_regressor,
    sign=1.0, plausible=(0.0, 1e13))
