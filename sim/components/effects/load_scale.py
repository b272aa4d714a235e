"""Stated-load error: the piston works against a load other than the one the records state.

Bond-graph change: an effort source on the piston-velocity 1-junction ``cylinder.rod``::

    1[ẋ] ── Se(ΔF)        ΔF = −k_F·F_load

The model applies the stated load as ``SeF_load`` (paper 002 eqs. 28, 38; zero in the
return phase, eq. 52).  When the stated load is off by a fraction — a load cell whose gain
drifted, a load-control valve whose 10/20/30 bar settings (paper 002 §3) give a little
more or less than their nominal back-pressure, an added fixture mass — the true load is
``(1 + k_F)·F_load``; the source adds the difference.  ``k_F`` [-] may have either sign.
Like the speed offset (paper 000 §5: an offset traced to a wrong speed reading) this is an
error of a stated condition, not of the rig: a rig version that carries it applies the
correction to every condition it is given.  It scales the load stated as a force, the way
paper 002 models its load valve; a rig loaded through ``load.back_pressure`` (the valve as a
pressure in the outlet line, :mod:`sim.components.load`) has a zero force column, and an
error in that back-pressure is no case of this entry (the workflow answers "unexplained").

Signature in the piston force balance: ``A1·P1 − A2·P2 − F_load`` exceeds the friction
by ``k_F·F_load`` — the stated load itself, at every load of the records and zero in the
return stroke.  On a design whose records differ in load, pressure-dependent seal friction
(``k_p·(P1 + P2)·sgn ẋ``) is its nearest neighbour: both grow with load in the working
stroke; the seal friction also acts in the return stroke and at the base pressure.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, Se
from sim.bondgraph.laws import law
from sim.components.base import declare
from sim.components.effects.base import Arr, EffectEntry
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "build", "load_excess"]

NAME = "load_scale"

PARAMETERS: tuple[Param, ...] = (
    Param("k_F", "1", 0.0, "effect strength, fitted (0 = off)",
          "fractional error of the stated load (true/stated − 1)", lower=-0.5, upper=0.5,
          lower_inclusive=True),
)


@law
def load_excess(force: float, k_F: float) -> float:
    """ΔF = −k_F·F_load [N]: the effort of the extra load on the piston junction (it
    resists extension like ``SeF_load``, paper 002 eq. 38)."""
    return -k_F * force


def _stated(condition: Mapping[str, float | None], values: Mapping[str, float]) -> str | None:
    """The load the piston works against for the one stated (:attr:`EffectEntry.stated`)."""
    k_f, load = values.get(f"{NAME}.k_F", 0.0), condition.get("load")
    if not k_f or not load:
        return None
    return (f"this rig version carries a stated-load correction ({NAME}, k_F = {k_f:.4g}): "
            f"the piston works against {(1 + k_f) * load:.5g} N for the {load:.5g} N stated")


def _regressor(s: Mapping[str, Arr]) -> Arr:
    return np.asarray(s["load"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the piston works against a load a fixed fraction off the stated one "
                "(load cell gain, load-valve setting): extra force ∝ the stated load",
    reference="paper 002 eqs. 28, 38, 52 (SeF_load, zero in the return phase) and §3 "
              "(load set as a 10/20/30 bar back-pressure)",
    circuit="pump-valve-cylinder", balance="piston_force", coefficient="k_F",
    signature="F_load (stated; 0 in the return stroke)", regressor=_regressor, sign=0.0,
    plausible=(-0.1, 0.1), stated=_stated)


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None) -> None:
    """Add the source ``−k_F·F_load`` on ``cylinder.rod`` (module docstring)."""
    declare(g, name, PARAMETERS, values)
    g.add(Se(f"{name}.Se", load_excess, "p:load.force", f"p:{name}.k_F",
             description="ΔF = −k_F·F_load"))
    g.connect(f"{name}.Se", "cylinder.rod", label=f"{name}.Se")
