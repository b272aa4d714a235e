"""Compressibility loss of the pump: oil carried back from the outlet, compressed, each turn.

Paper 000 eq. 6 (and its MSf COMP of Figure 7): the displacement chambers are filled at the
inlet pressure and delivered at the outlet pressure, so each revolution the oil compressed
in the trapped and dead volumes is lost to the outlet flow, ``Q_c = Δp·D·ω/β``.  Paper 002's
pump (eqs. 1-5) has only the laminar leak ``P/Rlp``.

Bond-graph change: an R (flow out) from the pump outlet 0-junction ``pump.out`` to the tank::

    0[Pp] ── R(Q_c)        Q_c = k_b·Pp·Vp·ω

``k_b = 1/β_c`` [1/Pa] lumps the bulk modulus and the ratio of compressed to displaced
volume; k_b = 0 (the default) is the base pump exactly.  It dissipates (P·Q_c ≥ 0).

Signature in the pump-outlet balance: ``P·ω·Vp``.  At one shaft speed (paper 002: 1600 rpm)
this is the laminar leak's column ``P`` times a constant: the two cannot be told apart on
such a test design (DISCREPANCY.md: only a speed change splits them).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, call
from sim.bondgraph.laws import law
from sim.components.effects.base import PUMP_CIRCUITS, Arr, EffectEntry, leak_to_tank
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build", "compression_flow"]

NAME = "pump_compressibility_loss"

PARAMETERS: tuple[Param, ...] = (
    Param("k_b", "1/Pa", 0.0, "effect strength, fitted (0 = off); paper 000 eq. 6 (COMP)",
          "compressibility coefficient 1/β_c of the oil carried round by the pump",
          lower=0.0, upper=1e-8, lower_inclusive=True),
)


@law
def compression_flow(p: float, k_b: float, Vp: float, omega: float) -> float:
    """Q_c = k_b·P·Vp·ω [m³/s] (paper 000 eq. 6, the compressibility term)."""
    return k_b * p * Vp * omega


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Add the compressibility-loss R on ``pump.out`` (module docstring)."""
    leak_to_tank(g, name, "pump.out", PARAMETERS, values,
                 call(compression_flow, "e", f"p:{name}.k_b", "p:pump.Vp", "p:pump.speed"),
                 "Q_c = k_b·P·Vp·ω", leakage=False)


def _regressor(s: Mapping[str, Arr]) -> Arr:
    return np.asarray(s["P_pump"] * s["speed"] * s["Vp"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="oil compressed in the pump's chambers and carried back each turn: a flow "
                "loss ∝ P·ω",
    reference="paper 000 eq. 6 (compressibility term, MSf COMP of Figure 7)",
    circuit="pump-valve-cylinder", balance="pump_flow", coefficient="k_b",
    signature="P_pump·ω·Vp", regressor=_regressor, sign=1.0, plausible=(0.0, 2e-9),
    also=PUMP_CIRCUITS)
