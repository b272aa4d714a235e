"""Viscous pump slip: the pump's internal leak is laminar and grows as the oil thins.

Paper 000 eqs. 4 and 6: the laminar (Poiseuille) slip through a pump's gaps is
``Q_s = C_s·Δp·D/μ(T)`` — inversely proportional to the viscosity, so it doubles when
the oil warms from 40 °C to about 60 °C (ISO VG 46).  Paper 002's pump (eqs. 1-5) holds
one constant leak resistance ``Rlp``, right at the temperature it was identified at: a
rig file with that pump misses the leak's temperature dependence.  Found on measured data:
the plateau flows of the ZeMA rig's healthy pump at 35-58 °C (``make real-data``,
:mod:`benchmarks.real_discrepancy`) leave a residual that grows as 1/μ.

Bond-graph change: an R (flow out) from the pump outlet 0-junction ``pump.out`` to the
tank, in parallel with the stored leak::

    0[Pp] ── R(Q_v)        Q_v = C_s·Pp·Vp/μ(T)

``C_s`` [-] is paper 000's laminar slip coefficient of the viscous part of the leak
(``Vp`` per radian, μ at the operating condition's oil temperature, ``fluid.mu``); 0 (the
default) is the base pump exactly.  It dissipates (P·Q_v ≥ 0).

Signature in the pump-outlet balance: ``P·Vp/μ``.  The base's laminar leak ``P/Rlp`` is
re-fitted beside it, so only the part that changes with the oil temperature tells: on
records at one temperature the two are the same column (DISCREPANCY.md: several
temperatures separate slip ∝ Δp/μ from a constant leak), and over one pressure level it
is the column of ``pump_clearance_pressure`` (P²/μ) times a constant.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, call
from sim.bondgraph.laws import law
from sim.components.effects.base import PUMP_CIRCUITS, Arr, EffectEntry, leak_to_tank
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build", "viscous_slip_flow"]

NAME = "viscous_pump_slip"

PARAMETERS: tuple[Param, ...] = (
    Param("C_s", "1", 0.0, "effect strength, fitted (0 = off); paper 000 eq. 4",
          "laminar slip coefficient C_s of the viscous part of the pump's leak "
          "(Q_s = C_s·Δp·D/μ)", lower=0.0, upper=1e-6, lower_inclusive=True),
)


@law
def viscous_slip_flow(p: float, C_s: float, Vp: float, mu: float) -> float:
    """Q_s = C_s·P·Vp/μ [m³/s] (paper 000 eqs. 4 and 6, the laminar slip)."""
    return C_s * p * Vp / mu


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Add the viscous-slip R on ``pump.out`` (module docstring)."""
    leak_to_tank(g, name, "pump.out", PARAMETERS, values,
                 call(viscous_slip_flow, "e", f"p:{name}.C_s", "p:pump.Vp", "p:fluid.mu"),
                 "Q_s = C_s·P·Vp/μ")


def _regressor(s: Mapping[str, Arr]) -> Arr:
    return np.asarray(s["P_pump"] * s["Vp"] / s["mu"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the pump's internal leak is laminar: it grows as the oil thins (∝ P/μ), "
                "where the stored pump holds one constant leak resistance",
    reference="paper 000 eqs. 4 and 6 (laminar slip Q_s = C_s·Δp·D/μ)",
    circuit="pump-valve-cylinder", balance="pump_flow", coefficient="C_s",
    signature="P_pump·Vp/μ(T)", regressor=_regressor, sign=1.0, plausible=(0.0, 1e-7),
    also=PUMP_CIRCUITS)
