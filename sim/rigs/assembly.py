"""Assemble the bond graph of a rig and turn (rig, overrides, condition) into parameter vectors."""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from sim.bondgraph import BondGraph, CompiledModel, compile_graph
from sim.components.base import Derivation
from sim.components.effects import get_effect
from sim.errors import InputError, ParameterError
from sim.fluid import Fluid
from sim.numbers import field_number
from sim.params import broken_relation
from sim.rigs.circuits import DEFAULT_CIRCUIT, Circuit, get_circuit, require_cycle
from sim.rigs.schema import RigSpec, check_bounds

#: Highest pump shaft speed a condition may state [rad/s]: ~19,000 rpm, twice the fastest
#: hydraulic pumps (chosen; a rig simulated beyond it would report pressures no relief
#: valve of the circuit allows, and a reading beyond it is taken to be an error).
MAX_PUMP_SPEED = 2000.0
#: most a condition's pump speed, or an override of its displacement, may exceed the rig's
#: stated one [-]
OVERSPEED = 3.0

__all__ = ["MAX_PUMP_SPEED", "OVERSPEED", "Condition", "Rig", "build_graph", "build_graph_with_effects",
           "check_overrides", "require_rig"]

Arr = npt.NDArray[np.float64]

#: name of a ``condition:`` block entry → attribute of :class:`Condition`
_CONDITION_ATTRIBUTES = {"force": "load", "back_pressure": "back_pressure",
                         "oil_temperature": "oil_temperature"}


def check_overrides(overrides: object) -> None:
    """Refuse ``overrides`` that are not a mapping ``role.name`` → value (a list of pairs
    raised "'list' object has no attribute 'get'", a key ``1`` "'int' object has no
    attribute 'partition'": a library user's pass)."""
    if overrides is not None and not isinstance(overrides, Mapping):
        raise ParameterError(f"overrides are a mapping 'role.name' → value [SI], e.g. "
                             f"{{'valve.cv': 6e-5}}, not a {type(overrides).__name__}",
                             field="overrides")
    for key in overrides or {}:
        if not isinstance(key, str):
            raise ParameterError(f"an override's key is its parameter's name 'role.name' "
                                 f"(e.g. 'valve.cv'), not {key!r} ({type(key).__name__})",
                                 field="overrides")


def _number(value: object, field: str) -> float:
    """``value`` as a float, or a :class:`ParameterError` naming ``field``: an array, None,
    "60 um" or 10**400 raised a bare TypeError, ValueError or OverflowError (a library
    user's pass)."""
    return field_number(value, field, error=ParameterError, expected="a number in SI units")


@dataclass(frozen=True)
class Condition:
    """Operating condition of a run.

    Attributes
    ----------
    load
        Load force resisting extension in the working phase [N] (paper 002: 2.1/4.2/6.3 kN).
    back_pressure
        Back-pressure of the load valve in the cylinder outlet line, working phase [Pa].
    oil_temperature
        Oil temperature [°C].
    pump_speed
        Pump shaft speed [rad/s]; ``None`` keeps the rig's value.
    """

    load: float = 2.1e3
    back_pressure: float = 0.0
    oil_temperature: float = 40.0
    pump_speed: float | None = None


def build_graph(circuit: str = DEFAULT_CIRCUIT) -> tuple[BondGraph, list[Derivation]]:
    """The bond graph of the registered ``circuit``, with default parameters."""
    return get_circuit(circuit).build(circuit)


@dataclass
class Rig:
    """A rig ready to simulate: its spec, compiled model and parameter derivations."""

    spec: RigSpec
    model: CompiledModel
    derivations: list[Derivation]
    fluid: Fluid
    base: dict[str, float] = field(default_factory=dict)

    def __repr__(self) -> str:
        """One line (the generated one printed the compiled equations: 62 kB in a notebook,
        a library user's pass)."""
        effects = f", effects={list(self.spec.effect_types)}" if self.spec.effect_types else ""
        return (f"Rig(name={self.spec.name!r}, circuit={self.circuit.name!r}, "
                f"parameters={len(self.base)}, states={len(self.model.state_names)}{effects})")

    @property
    def circuit(self) -> Circuit:
        """The circuit of the rig file."""
        return self.spec.circuit

    def require_cycle(self, what: str) -> None:
        """Raise :class:`CircuitError` (``field="rig_id"``) unless the rig's circuit has the
        cylinder's working/return cycle that ``what`` runs (:attr:`Circuit.cycle`)."""
        require_cycle(self.circuit, self.spec.name, what)

    @classmethod
    def from_spec(cls, spec: RigSpec) -> Rig:
        """Compile the circuit and keep the rig's parameter values."""
        _, derivations = _graph_cached(spec.circuit, spec.effect_types)
        model = _model_cached(spec.circuit, spec.effect_types)
        fl = spec.fluid_model()
        base = spec.values()
        unknown = set(base) - set(model.param_names)
        if unknown:
            raise ParameterError(f"parameters not in the circuit: {sorted(unknown)}")
        return cls(spec, model, derivations, fl, base)

    def default_condition(self) -> Condition:
        """The rig file's default operating condition."""
        c = self.spec.condition
        return Condition(
            load=c["force"].value if "force" in c else 2.1e3,
            back_pressure=c["back_pressure"].value if "back_pressure" in c else 0.0,
            oil_temperature=c["oil_temperature"].value if "oil_temperature" in c else 40.0,
        )

    @staticmethod
    def _check_speed(speed: float, stated: float | None, field: str) -> None:
        """Refuse a pump speed [rad/s] beyond :data:`MAX_PUMP_SPEED` or more than
        :data:`OVERSPEED` times the rig's ``stated`` one, naming ``field``: rpm typed where
        rad/s is asked passed the 2000 rad/s ceiling unnoticed (a user pass: 1450 "rpm" ran
        the pump at 13,850 rpm, 221 L/min), as a condition and, until now, as an override
        of ``pump.speed``."""
        if not 0 < speed <= MAX_PUMP_SPEED:
            raise ParameterError(f"pump speed must be > 0 and ≤ {MAX_PUMP_SPEED:g} rad/s "
                                 f"(~19,000 rpm), got {speed:g}", field=field)
        if stated is not None and speed > OVERSPEED * stated:
            raise ParameterError(
                f"pump speed {speed:g} rad/s ({speed * 30 / math.pi:.0f} rpm) is more than "
                f"{OVERSPEED:g} times the rig's {stated:.4g} rad/s "
                f"({stated * 30 / math.pi:.0f} rpm): pump speeds are in rad/s (1 rpm = "
                "π/30 rad/s)", field=field)

    @staticmethod
    def _check_displacement(vp: float, stated: float | None) -> None:
        """Refuse a displacement override [m³/rad] more than :data:`OVERSPEED` times the
        rig's: the rig file and the papers state it per revolution, and 1.75e-5 "m³/rad"
        ran the pump 2π times too large, the piston at 1.37 m/s (a library user's pass)."""
        if stated is not None and vp > OVERSPEED * stated:
            raise ParameterError(
                f"displacement {vp:g} m³/rad is more than {OVERSPEED:g} times the rig's "
                f"{stated:.4g} m³/rad ({stated * 2 * math.pi * 1e6:.4g} cm³/rev): an override "
                f"is in m³/rad (m³/rev ÷ 2π; {vp:g} m³/rev is {vp / (2 * math.pi):.4g} "
                "m³/rad)", field="overrides.pump.Vp")

    def _check_relations(self, v: Mapping[str, float], overrides: Mapping[str, float]) -> None:
        """Refuse overrides that break their component's geometry (a rod thicker than the
        bore, a clearance wider than the radius), naming the override."""
        circuit = self.spec.circuit
        for role in {key.partition(".")[0] for key in overrides}:
            relations = circuit.relations(role)
            if not relations:
                continue
            prefix = f"{role}."
            own = {k.removeprefix(prefix): x for k, x in v.items() if k.startswith(prefix)}
            if (broken := broken_relation(relations, own)) is not None:
                key = f"{role}.{broken.name}"
                if key not in overrides:
                    key = next(k for k in overrides if k.startswith(prefix))
                raise ParameterError(f"{broken.text} (with the overrides given)",
                                     field=f"overrides.{key}")

    def channels(self) -> dict[str, str]:
        """The model's outputs, the channels a measured series of the rig may carry, and
        their SI units (``P1`` → ``Pa``)."""
        return dict(zip(self.model.output_names, self.model.output_units, strict=True))

    def check_condition(self, cond: Condition) -> None:
        """Refuse a condition outside the range the circuit is modelled for.

        Raises
        ------
        ParameterError
            Naming the circuit's condition parameter (``condition.force``,
            ``condition.oil_temperature``).
        """
        for decl in self.spec.circuit.condition:
            attribute = _CONDITION_ATTRIBUTES.get(decl.name, decl.name)
            try:
                check_bounds(_number(getattr(cond, attribute), f"condition.{decl.name}"),
                             decl, f"condition.{decl.name}")
            except ParameterError as exc:
                raise ParameterError(exc.message, field=exc.field) from None

    def values(self, overrides: Mapping[str, float] | None = None,
               condition: Condition | None = None) -> dict[str, float]:
        """All graph parameter values for ``overrides`` (``role.name`` → SI) and ``condition``."""
        cond = condition if condition is not None else self.default_condition()
        if not isinstance(cond, Condition):
            # a dict gave "'dict' object has no attribute 'load'" (a library user's pass)
            raise ParameterError(f"a condition is a sim.rigs.Condition(load=…, "
                                 f"oil_temperature=…), not a {type(cond).__name__}",
                                 field="condition")
        check_overrides(overrides)
        v = dict(self.base)
        circuit = self.spec.circuit
        for key, raw in (overrides or {}).items():
            value = _number(raw, f"overrides.{key}")
            role, _, pname = key.partition(".")
            decl = circuit.parameter(role, pname)
            if decl is None and role in self.spec.effects:
                decl = get_effect(role).parameter(pname)
            if decl is None:
                raise ParameterError(f"unknown parameter {key!r} (use role.name, e.g. "
                                     "'cylinder.cc')", field=f"overrides.{key}")
            try:
                check_bounds(float(value), decl, f"overrides.{key}")
            except ParameterError as exc:
                raise ParameterError(exc.message, field=exc.field) from None
            v[key] = float(value)
        if overrides:
            if "pump.speed" in overrides:  # against the rig's own speed first: the sharper note
                self._check_speed(float(overrides["pump.speed"]), self.base.get("pump.speed"),
                                  "overrides.pump.speed")
            if "pump.Vp" in overrides:
                self._check_displacement(float(overrides["pump.Vp"]), self.base.get("pump.Vp"))
            self._check_relations(v, overrides)
        self.check_condition(cond)
        if cond.pump_speed is not None:
            self._check_speed(_number(cond.pump_speed, "condition.pump_speed"),
                              v.get("pump.speed"), "condition.pump_speed")
            v["pump.speed"] = cond.pump_speed
        for attribute, target in circuit.condition_targets.items():
            v[target] = getattr(cond, attribute)
        T = cond.oil_temperature
        v["fluid.mu"] = self.fluid.dynamic_viscosity(T)
        v["fluid.rho"] = self.fluid.density(T)
        v["fluid.beta"] = self.fluid.beta
        for name in self.spec.effect_types:
            # effects on a fluid property (a wrong μ(T) law) before anything derives from it
            v.update(get_effect(name).fluid_values(v, T))
        for d in self.derivations:
            v.update(d(v))
        return v

    def params(self, overrides: Mapping[str, float] | None = None,
               condition: Condition | None = None,
               graph_values: Mapping[str, float] | None = None) -> Arr:
        """Parameter vector of the compiled model.

        ``graph_values`` sets raw graph parameters last (``{"valve.N": -1.0}``); the
        cycle runner uses it for the phase settings.
        """
        v = self.values(overrides, condition)
        v.update(graph_values or {})
        return self.model.params(v)


def require_rig(rig: object, field: str = "rig") -> Rig:
    """``rig`` when it is a compiled :class:`Rig`, else an :class:`~sim.errors.InputError`
    naming ``field``: None or a rig document raised "'NoneType' object has no attribute
    'require_cycle'" (a library user's pass)."""
    if not isinstance(rig, Rig):
        hint = (": compile a document with sim.rigs.load_rig(document)"
                if isinstance(rig, Mapping | str) else "")
        raise InputError(f"a compiled rig (sim.rigs.load_rig, reference_rig) is expected, not "
                         f"a {type(rig).__name__}{hint}", field=field)
    return rig


#: cache key: (circuit name, sorted effect names)
_Key = tuple[str, tuple[str, ...]]
_GRAPHS: dict[_Key, tuple[BondGraph, list[Derivation]]] = {}
_MODELS: dict[_Key, CompiledModel] = {}
#: each (circuit, effects) is built and compiled once per process, even under concurrent
#: first calls
_CACHE_LOCK = threading.Lock()


def build_graph_with_effects(circuit: Circuit, effects: tuple[str, ...] = ()
                             ) -> tuple[BondGraph, list[Derivation]]:
    """The circuit's bond graph with the library ``effects`` added (default parameters)."""
    graph, derivations = circuit.build(circuit.name)
    for name in effects:
        get_effect(name, circuit.name).build(graph)
    return graph, derivations


def _graph_cached(circuit: Circuit, effects: tuple[str, ...] = ()
                  ) -> tuple[BondGraph, list[Derivation]]:
    key = (circuit.name, effects)
    with _CACHE_LOCK:
        if key not in _GRAPHS:
            _GRAPHS[key] = build_graph_with_effects(circuit, effects)
        return _GRAPHS[key]


def _model_cached(circuit: Circuit, effects: tuple[str, ...] = ()) -> CompiledModel:
    graph = _graph_cached(circuit, effects)[0]
    key = (circuit.name, effects)
    with _CACHE_LOCK:
        if key not in _MODELS:
            _MODELS[key] = compile_graph(graph)
        return _MODELS[key]
