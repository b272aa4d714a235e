"""The library of named candidate effects (issue 8): what a rig model may be missing.

Each entry couples a catalogue line (:class:`~sim.components.effects.base.EffectEntry`:
name, physics, reference, regressor signature, sign and plausible range), its parameter
declarations (strength 0 = off) and the bond-graph change that adds it to a circuit at
named junctions.  A rig document lists effects in its optional ``effects:`` section
(:mod:`sim.rigs.schema`); :mod:`sim.rigs.assembly` builds circuit + effects and caches
the compiled model per (circuit, effect types).

Registered, circuit ``pump-valve-cylinder`` (paper 002):

==============================  ===============  =========================================
effect                          balance          bond-graph change
==============================  ===============  =========================================
``stribeck_friction``           piston force     R on ``cylinder.rod``
``seal_friction_pressure``      piston force     R on ``cylinder.rod`` reading P1, P2
``couette_drag``                piston force     R on ``cylinder.rod`` reading μ(T)
``load_scale``                  piston force     Se on ``cylinder.rod`` reading the
                                                 stated load (a stated-condition error)
``turbulent_piston_leakage``    chamber flow     1-junction + R across ``cylinder.c1/c2``
``piston_clearance_pressure``   chamber flow     1-junction + R across ``cylinder.c1/c2``
``turbulent_spool_leakage``     valve flow       1-junction + R across ``valve.P/T``
``turbulent_pump_slip``         pump flow        R on ``pump.out``
``pump_clearance_pressure``     pump flow        R on ``pump.out``
``speed_offset``                pump flow        Sf on ``pump.out``
``pump_compressibility_loss``   pump flow        R on ``pump.out`` reading Vp, ω
``viscous_pump_slip``           pump flow        R on ``pump.out`` reading Vp, μ(T)
``pump_filling``                pump flow        MSf on ``pump.out`` reading Vp and the
                                                 shaft's ω (flow drawn: k_f·Vp·ω²)
``viscosity_law``               chamber flow     ``fluid.mu`` × exp(−λ(T − T_ref)) for
                                                 every viscous R (a fluid correction)
``entrained_air``               chamber flow     law of C ``cylinder.C1/C2``: + air
                                                 compliance α0·V·(p_a/p)^(1/n)/(n·p)
``relief_override``             relief flow      law of R ``relief``: P − Pset = Rrv·Q +
                                                 k_ov·Q²
``line_unsteady_friction``      hose pressure    law of I ``hose_A/B.I``: × (1 + k3)
==============================  ===============  =========================================

The last four change a fluid property or an existing element's constitutive law rather
than adding an element (the element keeps its place and causality).  On the paper-002
logger's channels, ``line_unsteady_friction`` enters no balance (its effort balance needs
the pressure at valve port B, ``P_valve_B``: logged, the ``hose_pressure`` balance reads
it), and ``relief_override`` shows only while the relief passes
flow, which a cycle whose phases end at the end stops never does: it needs records with a
dwell at the stop (:data:`diagnostics.discrepancy.synthetic.DWELLS`), where the
``relief_flow`` balance of :mod:`diagnostics.discrepancy.balances` reads it.

circuit ``gear-pump-field`` (paper 000 Figure 7 duty cycle, :mod:`sim.duty_cycle`):

==============================  ===============  =========================================
effect                          balance          bond-graph change
==============================  ===============  =========================================
``side_plate_lag``              field flow       lag state p_sp + MSf on ``pump.core``
``slip_hysteresis``             field flow       play-memory state m + MSf on ``pump.core``
==============================  ===============  =========================================

:func:`effects_for` lists the entries of one circuit (the hidden-effect bench of a circuit
iterates it).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from types import MappingProxyType

import numpy as np
import numpy.typing as npt

from sim.bondgraph import BondGraph
from sim.components.effects import (
    compressibility_loss,
    couette_drag,
    entrained_air,
    line_unsteady_friction,
    load_scale,
    pressure_clearance,
    pump_filling,
    relief_override,
    seal_friction_pressure,
    side_plate_lag,
    slip_hysteresis,
    speed_offset,
    stribeck_friction,
    turbulent_leakage,
    viscosity_law,
    viscous_pump_slip,
)
from sim.components.effects.base import EffectEntry
from sim.errors import RigFileError
from sim.params import Param

Arr = npt.NDArray[np.float64]

__all__ = ["EFFECTS", "Effect", "EffectEntry", "FluidCorrection", "effects_for", "get_effect"]

#: (graph parameter values, oil temperature [°C]) → corrected ``fluid.*`` values
FluidCorrection = Callable[[Mapping[str, float], float], dict[str, float]]


@dataclass(frozen=True)
class Effect:
    """A library effect: catalogue entry, parameters and graph builder.

    ``build(g)`` adds the effect to a graph holding the entry's circuit, with parameters
    named ``{entry.name}.{param}``.  ``frozen`` names the auxiliary states the effect adds
    that a steady solution must hold at their guess (a memory whose every value within a
    band is an equilibrium).  ``fluid`` corrects the fluid parameters (``fluid.mu`` ...)
    at the operating condition's oil temperature: an effect on a property that every
    element reads rather than an added element (:meth:`fluid_values`).
    """

    entry: EffectEntry
    parameters: tuple[Param, ...]
    build: Callable[[BondGraph], None]
    frozen: tuple[str, ...] = ()
    fluid: FluidCorrection | None = None

    @property
    def name(self) -> str:
        """The effect's name."""
        return self.entry.name

    def fluid_values(self, values: Mapping[str, float], T: float) -> dict[str, float]:
        """Corrected fluid parameters at oil temperature ``T`` [°C] (empty if none).

        ``values`` are the graph parameter values with the stated fluid properties;
        :meth:`sim.rigs.assembly.Rig.values` applies this before the components derive
        their coefficients from ``fluid.*``.
        """
        return {} if self.fluid is None else self.fluid(values, T)

    def parameter(self, name: str) -> Param | None:
        """The declaration of parameter ``name``, or ``None``."""
        return next((p for p in self.parameters if p.name == name), None)


def _single(module: object) -> Effect:
    entry: EffectEntry = module.ENTRY  # type: ignore[attr-defined]
    builder = module.build  # type: ignore[attr-defined]
    frozen = tuple(f"{entry.name}.{s}" for s in getattr(module, "FROZEN", ()))
    fluid = getattr(module, "fluid_values", None)
    return Effect(entry, module.PARAMETERS,  # type: ignore[attr-defined]
                  lambda g: builder(g, entry.name), frozen,
                  None if fluid is None else partial(fluid, name=entry.name))


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
for _m in (stribeck_friction, seal_friction_pressure, couette_drag, speed_offset,
           compressibility_loss, side_plate_lag, slip_hysteresis, viscosity_law,
           relief_override, entrained_air, line_unsteady_friction, viscous_pump_slip,
           load_scale, pump_filling):
    _e = _single(_m)
    _REGISTRY[_e.name] = _e
for _m in (turbulent_leakage, pressure_clearance):
    _REGISTRY.update(_paths(_m))

#: read-only view of the library, by effect name
EFFECTS: Mapping[str, Effect] = MappingProxyType(_REGISTRY)


def effects_for(circuit: str) -> dict[str, Effect]:
    """The library entries that apply to ``circuit``, by name."""
    return {k: e for k, e in _REGISTRY.items() if e.entry.applies_to(circuit)}


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
    if circuit is not None and not effect.entry.applies_to(circuit):
        where = " or ".join(repr(c) for c in (effect.entry.circuit, *effect.entry.also))
        raise RigFileError(f"effect {name!r} applies to circuit {where}, not {circuit!r}",
                           field=field)
    return effect


def parameter_bounds(keys: Sequence[str]) -> tuple[Arr, Arr]:
    """Declared lower and upper bounds of effect parameters named ``effect.param``.

    A missing bound is ±inf (what :func:`scipy.optimize.least_squares` takes), in each
    parameter's SI unit.
    """
    lo, hi = [], []
    for key in keys:
        name, _, pname = key.partition(".")
        decl = get_effect(name).parameter(pname)
        if decl is None:
            raise RigFileError(f"effect {name!r} has no parameter {pname!r}", field="effects")
        lo.append(-np.inf if decl.lower is None else decl.lower)
        hi.append(np.inf if decl.upper is None else decl.upper)
    return np.array(lo, dtype=float), np.array(hi, dtype=float)
