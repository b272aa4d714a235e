"""Unsteady line friction: the hoses resist a change of flow more than their oil column.

The base model gives each hose the inertance of its oil column, I = ρ·L/A, and the
steady Hagen-Poiseuille resistance (:mod:`sim.components.hose`).  When the flow
accelerates, the velocity profile lags and the wall shear exceeds its steady value
(frequency-dependent friction, Zielke 1968).  The instantaneous-acceleration model of
Brunone, Golia & Greco (*Proc. Int. Meeting on Hydraulic Transients with Column
Separation*, IAHR, Valencia, 1991, 201-209; Vardy & Brown, *J. Hydraul. Res.* 33, 1995)
writes the extra shear as ``k3·(ρ·L/A)·dQ/dt``; in a lumped hose with one segment (no
convective term) that is the inertance scaled::

    Δp_line = R·Q + (1 + k3)·(ρ·L/A)·dQ/dt

k3 [-] is the strength (Brunone's coefficient; 0.01-0.1 for laminar oil flow, larger in
fast transients).  It is chosen over an "inertance error" (a longer or narrower line
than stated) because a wrong L or d also changes the hose's R and C: that is a
base-parameter error the re-fit of ``hose_*.d``/``L`` covers, whereas unsteady friction is
physics the lumped model lacks.  k3 = 0 (the default) is the base hose exactly.

Bond-graph change: the I elements of both hoses (``hose_A.I``, ``hose_B.I``) on their
1-junctions keep their place and integral causality; their inertance law becomes
:func:`scaled_inertance`.  An I stores and returns energy (no dissipation added).

Signature: the hose's effort balance ``P_port − P_chamber − R·Q = (1 + k3)·I·Q̇`` needs the
pressure at the valve's A/B port, which the paper-002 logger does not record; no balance
of :mod:`diagnostics.discrepancy.balances` evaluates it.  On that rig the whole base
inertance term is ≈ 0.3 bar for the first ~50 ms after a valve switch (I = 3.4e6 kg/m⁴,
Q̇ ≈ 1e-2 m³/s²), where the balances leave samples out; an unsteady friction of
k3 ≤ 0.1 stays below the 0.05 bar pressure noise.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, LawCall
from sim.bondgraph.laws import constant, law
from sim.components.base import declare
from sim.components.effects.base import Arr, EffectEntry
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build", "scaled_inertance"]

NAME = "line_unsteady_friction"
#: the hose inertances the effect changes (paper-002 circuit)
LINES = ("hose_A.I", "hose_B.I")

PARAMETERS: tuple[Param, ...] = (
    Param("k3", "1", 0.0, "effect strength, fitted (0 = off)",
          "Brunone's unsteady-friction coefficient (extra inertance fraction)", lower=0.0,
          upper=2.0, lower_inclusive=True),
)


@law
def scaled_inertance(I_line: float, k3: float) -> float:
    """(1 + k3)·I [kg/m⁴]: the oil column's inertance plus the unsteady wall shear.

    Brunone, Golia & Greco 1991 (instantaneous-acceleration unsteady friction);
    k3 = 0 returns ``I_line`` exactly.
    """
    if k3 == 0.0:
        return I_line
    return (1.0 + k3) * I_line


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Give both hoses' inertances the unsteady-friction factor (module docstring)."""
    declare(g, name, PARAMETERS, values)
    for line in LINES:
        el = g.elements[line]
        assert el.law is not None and el.law.func is constant
        el.law = LawCall(scaled_inertance, (*el.law.args, f"p:{name}.k3"))
        el.description += " × (1 + k3), unsteady friction"


def _regressor(s: Mapping[str, Arr]) -> Arr:
    # hose B's effort balance, P2 − P_B − R·Q = (1 + k3)·I·Q̇ with Q = −Q_meter_C (chamber
    # 2 towards port B): needs P_B and the derivative dQ_meter_C, which no balance has yet
    return np.asarray(-s["I_hose_B"] * s["dQ_meter_C"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the hoses' wall shear lags a change of flow (unsteady friction): extra "
                "pressure drop ∝ dQ/dt, like a larger inertance",
    reference="Brunone, Golia & Greco, IAHR Hydraulic Transients (1991) 201-209; Vardy & "
              "Brown, J. Hydraul. Res. 33 (1995)",
    circuit="pump-valve-cylinder", balance="hose_pressure", coefficient="k3",
    signature="−I_B·dQ_C/dt (needs the valve-port pressure P_B)", regressor=_regressor, sign=1.0,
    plausible=(0.0, 0.5))
