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

Signature: hose B's effort balance ``P2 − P_B = R·Q_C + (1 + k3)·I·dQ_C/dt`` (Q_C out of
chamber 2, meter C) needs the pressure at the valve's B port, which the paper-002 logger
does not record: with that sensor logged (``P_valve_B``, an output of the circuit) the
``hose_pressure`` balance of :mod:`diagnostics.discrepancy.balances` evaluates it,
integrated over 20 ms windows so that no derivative of the measured pressures is needed
(:func:`diagnostics.discrepancy.signals.hose_integrals`); k3 multiplies ``I·ΔQ_C``.  The
effect lives in the hoses' oscillation after each valve switch and end-stop arrival
(tens of bar for ≈ 0.2 s on the paper-002 rig), partly faster than a 1 kHz logger
resolves: the balance leaves out the windows it cannot integrate and, at 1 kHz, names
k3 ≳ 0.1; without the port pressure the workflow has no balance for it and reports its
minimum detectable size as unknown (no candidate column).
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
    # hose B's effort balance integrated over a window (diagnostics.discrepancy.signals.
    # hose_integrals): ∫(P2 − P_B) dt = R·∫Q_C dt + (1 + k3)·I·ΔQ_C, the stated I·ΔQ_C
    # subtracted from the target, so k3 multiplies I·ΔQ_C
    return np.asarray(s["I_hose_B"] * s["hose.dq"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the hoses' wall shear lags a change of flow (unsteady friction): extra "
                "pressure drop ∝ dQ/dt, like a larger inertance",
    reference="Brunone, Golia & Greco, IAHR Hydraulic Transients (1991) 201-209; Vardy & "
              "Brown, J. Hydraul. Res. 33 (1995)",
    circuit="pump-valve-cylinder", balance="hose_pressure", coefficient="k3",
    signature="I_B·ΔQ_C over 20 ms in hose B's integrated effort balance (needs the "
              "valve-port pressure P_valve_B)", regressor=_regressor, sign=1.0,
    plausible=(0.0, 0.5))
