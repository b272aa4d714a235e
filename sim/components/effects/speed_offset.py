"""Speed-reading offset: the pump turns at a speed other than the one the model is given.

Bond-graph change: a flow source on the pump outlet 0-junction ``pump.out``::

    0[Pp] ── Sf(ΔQ)        ΔQ = Vp·Δω

Paper 000 §5 reports a flow offset traced to a wrong speed reading; a constant error Δω
[rad/s] in the imposed shaft speed (paper 002 eq. 1) adds ``Vp·Δω`` to the geometric flow
(eq. 2).  Δω may have either sign.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, Sf
from sim.bondgraph.laws import product
from sim.components.base import declare
from sim.components.effects.base import PUMP_CIRCUITS, Arr, EffectEntry
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build"]

NAME = "speed_offset"

PARAMETERS: tuple[Param, ...] = (
    Param("d_speed", "rad/s", 0.0, "effect strength, fitted (0 = off)",
          "error of the speed reading (true − stated)", lower=-200.0, upper=200.0,
          lower_inclusive=True),
)


def _stated(condition: Mapping[str, float | None], values: Mapping[str, float]) -> str | None:
    """The speed the pump delivers as, for the one stated (:attr:`EffectEntry.stated`): the
    condition's pump speed, else the rig's ``pump.speed``."""
    d_speed = values.get(f"{NAME}.d_speed", 0.0)
    speed = condition.get("pump_speed") or values.get("pump.speed")
    if not d_speed or not speed:
        return None
    rpm = 30.0 / math.pi
    return (f"this rig version carries a speed-reading correction ({NAME}, Δω = "
            f"{d_speed:.4g} rad/s): the pump delivers as at {(speed + d_speed) * rpm:.5g} rpm "
            f"for the {speed * rpm:.5g} rpm stated")


def _regressor(s: Mapping[str, Arr]) -> Arr:
    return np.asarray(-s["Vp"] * np.ones_like(s["P_pump"]), dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the shaft turns faster or slower than the stated speed: constant flow offset",
    reference="paper 000 §5 (offset from a wrong speed reading); paper 002 eqs. 1-2",
    circuit="pump-valve-cylinder", balance="pump_flow", coefficient="d_speed",
    signature="−Vp (constant)", regressor=_regressor, sign=0.0, plausible=(-20.0, 20.0),
    also=PUMP_CIRCUITS, stated=_stated)


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Add the flow source ``Vp·Δω`` on ``pump.out`` (module docstring)."""
    declare(g, name, PARAMETERS, values)
    g.add(Sf(f"{name}.Sf", product, "p:pump.Vp", f"p:{name}.d_speed",
             description="ΔQ = Vp·Δω"))
    g.connect(f"{name}.Sf", "pump.out", label=f"{name}.Sf")
