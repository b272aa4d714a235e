"""Incomplete filling of the pump's displacement chambers at speed: a flow deficit ∝ ω².

A displacement chamber (a gear pump's tooth space) must fill from the inlet while it passes
the suction port.  The oil accelerates into it through the inlet passage, whose pressure
drop grows with the square of the velocity, i.e. with ω²; the faster the shaft turns, the
shorter the time a chamber is open to the inlet and the lower the pressure in it, until
dissolved air comes out or the oil vaporises and part of the chamber is delivered empty.
The pump's maximum speed is set by this filling limit (Ivantysyn & Ivantysynova, *Hydrostatic
Pumps and Motors*, 2001: the suction/filling limit of the speed).  Neither source model has
it: paper 002's pump is ``Qp = ω·Vp`` (eq. 2) with one leak ``P/Rlp`` (eq. 5), and paper 000
leaves air and vapour in the flow out of its model (§2: they "cannot easily be quantified
from the results of standardized tests"; its eq. 2 has no term growing faster than ω).
Paper 001's Table 1 lists no ω² *flow* loss either: its ω² terms (Schlösser 1961,
Ivantysyan and Ivantysynova 2003, Jeong 2007) are torque losses of turbulent friction.
The ω² regressor is DISCREPANCY.md's (item 4: "ω²"; the prototype's "filling" effect).

Law, the lowest-order one that grows faster than the displacement flow: the unfilled share
of each chamber grows in proportion to the speed, ``k_f·ω``, so the flow lost is::

    Q_f = k_f·Vp·ω²                                    [m³/s]

``k_f`` [s/rad] is the unfilled share of the displacement per rad/s of shaft speed; 0 (the
default) is the base pump exactly.  A real pump fills completely up to a speed and then
loses flow steeply (a knee, not a parabola); over a bench's speeds the ω² term is the
smooth first-order form of that rise, as the other library entries are of theirs.

Bond-graph change: a flow source on the pump outlet 0-junction ``pump.out`` that draws
``Q_f`` from it, modulated by the shaft speed (the flow of the pump's shaft bond
``pump.shaft``, ω of paper 002 eq. 1)::

    0[Pp] ── MSf(−Q_f)        Q_f = k_f·Vp·ω²

Like the compressibility loss (paper 000 eq. 6) it is flow that no drain line carries, so it
does not count in ``Q_pump_leak``.  It takes power ``Pp·Q_f ≥ 0`` from the junction.

Signature in the pump-outlet balance (``ω·Vp − q = Δp/Rlp + Σ c_k·x_k``): ``Vp·ω²`` — ω²
times a constant on any one pump; with ``Vp`` in it the coefficient does not depend on the
pump's size and is restated for a re-fitted displacement as the other pump entries are
(:func:`diagnostics.discrepancy.pump_refit.on_refitted`).  Ambiguity: at one shaft speed
it is a constant, the column of a displacement error (ω) and of the speed offset, so it
cannot be named (ambiguity group ``base + pump_filling``, as ``speed_offset``'s); at two
speeds the pair {``speed_offset``, ``pump_filling``} spans what the displacement column
leaves; from three speeds on only the curvature of the flow over ω tells it from a
displacement error plus a speed offset.  On the bench study's design (four speeds, 50-125 %
of 1600 rpm; 5-50 bar; 40-60 °C), with the pump's own columns P and ω projected out, its
column correlates with the speed offset's at 0.95, the turbulent slip's at −0.87 and the
compressibility loss's at 0.77 (VIF 24 beside the base columns): the study names the speed
offset instead in 22 of 100 tables at 4 σ and 8 at 8 σ (``docs/discrepancy.md``).
Pressure and temperature do not enter it: several pressures separate it from the
compressibility loss (P·ω·Vp) and the slips.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, MSf
from sim.bondgraph.laws import law
from sim.components.base import declare
from sim.components.effects.base import PUMP_CIRCUITS, Arr, EffectEntry
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build", "filling_flow"]

NAME = "pump_filling"

PARAMETERS: tuple[Param, ...] = (
    Param("k_f", "s/rad", 0.0, "effect strength, fitted (0 = off); DISCREPANCY.md item 4 "
          "(regressor ω²), Ivantysyn & Ivantysynova 2001 (filling limit of the speed)",
          "unfilled share of the pump's displacement per rad/s of shaft speed "
          "(Q_f = k_f·Vp·ω²)", lower=0.0, upper=1e-3, lower_inclusive=True),
)


@law
def filling_flow(k_f: float, Vp: float, omega: float) -> float:
    """−Q_f = −k_f·Vp·ω² [m³/s]: the flow the filling deficit takes from the outlet
    junction (a source's flow is counted into the junction)."""
    return -k_f * Vp * omega * omega


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Add the filling-loss flow source on ``pump.out`` (module docstring)."""
    declare(g, name, PARAMETERS, values)
    g.add(MSf(f"{name}.MSf", filling_flow, f"p:{name}.k_f", "p:pump.Vp", "f:pump.shaft",
              description="Q_f = k_f·Vp·ω² drawn from the outlet (incomplete filling)"))
    g.connect(f"{name}.MSf", "pump.out", label=f"{name}.MSf")


def _regressor(s: Mapping[str, Arr]) -> Arr:
    return np.asarray(s["Vp"] * s["speed"] * s["speed"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the pump's chambers do not fill completely at speed (inlet losses ∝ ω²): a "
                "flow deficit ∝ Vp·ω²",
    reference="DISCREPANCY.md item 4 (regressor ω², the prototype's filling effect); "
              "Ivantysyn & Ivantysynova, Hydrostatic Pumps and Motors, 2001 (filling limit "
              "of the speed); not in papers 000 (§2 leaves air and vapour out) and 001 "
              "(Table 1's ω² terms are torque losses)",
    circuit="pump-valve-cylinder", balance="pump_flow", coefficient="k_f",
    signature="Vp·ω²", regressor=_regressor, sign=1.0, plausible=(0.0, 3e-4),
    also=PUMP_CIRCUITS)
