"""The library of named candidate effects (issue 8): what a rig model may be missing.

Each entry couples a catalogue line (:class:`~sim.components.effects.base.EffectEntry`:
name, physics, reference, regressor signature, sign and plausible range), its parameter
declarations (strength 0 = off) and the bond-graph change that adds it to a circuit at
named junctions.  A rig document lists effects in its optional ``effects:`` section
(:mod:`sim.rigs.schema`); :mod:`sim.rigs.assembly` builds circuit + effects and caches
the compiled model per (circuit, effect types).

Registered (circuit ``pump-valve-cylinder``):

==============================  ===============  =========================================
effect                          balance          bond-graph change
==============================  ===============  =========================================
``stribeck_friction``           piston force     R on ``cylinder.rod``
``seal_friction_pressure``      piston force     R on ``cylinder.rod`` reading P1, P2
``couette_drag``                piston force     R on ``cylinder.rod`` reading μ(T)
``turbulent_piston_leakage``    chamber flow     1-junction + R across ``cylinder.c1/c2``
``piston_clearance_pressure``   chamber flow     1-junction + R across ``cylinder.c1/c2``
``turbulent_spool_leakage``     valve flow       1-junction + R across ``valve.P/T``
``turbulent_pump_slip``         pump flow        R on ``pump.out``
``pump_clearance_pressure``     pump flow        R on ``pump.out``
``speed_offset``                pump flow        Sf on ``pump.out``
==============================  ===============  =========================================
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from types import MappingProxyType

from sim.bondgraph import BondGraph
from sim.components.effects import (
    couette_drag,
    pressure_clearance,
    seal_friction_pressure,
    speed_offset,
    stribeck_friction,
    turbulent_leakage,
)
from sim.components.effects.base import EffectEntry
from sim.errors import RigFileError
from sim.params import Param

__all__ = ["EFFECTS", "Effect", "EffectEntry", "get_effect"]


@dataclass(frozen=True)
class Effect:
    """A library effect: catalogue entry, parameters and graph builder.

    ``build(g)`` adds the effect to a graph holding the entry's circuit, with parameters
    named ``{entry.name}.{param}``.
    """

    entry: EffectEntry
    parameters: tuple[Param, ...]
    build: Callable[[BondGraph], None]

    @property
    def name(self) -> str:
        """The effect's name."""
        return self.entry.name

    def parameter(self, name: str) -> Param | None:
        """The declaration of parameter ``name``, or ``None``."""
        return next((p for p in self.parameters if p.name == name), None)


def _single(module: object) -> Effect:
    entry: EffectEntry = module.ENTRY  # type: ignore[attr-defined]
    builder = module.build  # type: ignore[attr-defined]
    return Effect(entry, module.PARAMETERS,  # type: ignore[attr-defined]
                  lambda g: builder(g, entry.name))


def _paths(module: object) -> dict[str, Effect]:
    out: dict[str, Effect] = {}
    for name, (entry, high, low) in module.entries().items():  # type: ignore[attr-defined]
        if low is None:
            build = partial(module.build_to_tank, name=name, high=high)  # type: ignore[attr-defined]
        else:
            build = partial(module.build_across, name=name, high=high,  # type: ignore[attr-defined]
                            low=low)
        out[name] = Effect(entry, module.PARAMETERS, build)  # type: ignore[attr-defined]
    return out


_REGISTRY: dict[str, Effect] = {}
for _m in (stribeck_friction, seal_friction_pressure, couette_drag, speed_offset):
    _e = _single(_m)
    _REGISTRY[_e.name] = _e
for _m in (turbulent_leakage, pressure_clearance):
    _REGISTRY.update(_paths(_m))

#: read-only view of the library, by effect name
EFFECTS: Mapping[str, Effect] = MappingProxyType(_REGISTRY)


def get_effect(name: object, circuit: str | None = None, *, field: str = "effects") -> Effect:
    """The library effect ``name`` (usable on ``circuit`` when given).

    Raises
    ------
    RigFileError
        Unknown effect, or one that does not apply to the circuit, naming ``field``.
    """
    effect = _REGISTRY.get(name) if isinstance(name, str) else None
    if effect is None:
        raise RigFileError(f"unknown effect {name!r} (known: {', '.join(_REGISTRY)})",
                           field=field)
    if circuit is not None and effect.entry.circuit != circuit:
        raise RigFileError(f"effect {name!r} applies to circuit {effect.entry.circuit!r}, "
                           f"not {circuit!r}", field=field)
    return effect
