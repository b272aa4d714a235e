"""Assemble the bond graph of a rig and turn (rig, overrides, condition) into parameter vectors."""

from __future__ import annotations

import threading
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from sim.bondgraph import BondGraph, CompiledModel, LawCall, compile_graph
from sim.bondgraph.laws import negated
from sim.components import (
    check_valve,
    cylinder,
    directional_valve,
    fixed_drop,
    hose,
    load,
    pump,
    relief_valve,
    throttle,
)
from sim.components.base import Derivation
from sim.errors import ParameterError
from sim.fluid import Fluid
from sim.rigs.schema import (
    CIRCUIT_ROLES,
    COMPONENT_TYPES,
    CONDITION_PARAMETERS,
    RigSpec,
    check_bounds,
)

__all__ = ["Condition", "Rig", "build_graph"]

Arr = npt.NDArray[np.float64]


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


def build_graph(name: str = "rig") -> tuple[BondGraph, list[Derivation]]:
    """The bond graph of the ``pump-valve-cylinder`` circuit, with default parameters."""
    g = BondGraph(name)
    for k, v in (("mu", 0.04), ("rho", 870.0), ("beta", 1.5e9)):
        g.parameter(f"fluid.{k}", v, {"mu": "Pa*s", "rho": "kg/m^3", "beta": "Pa"}[k],
                    "derived from the fluid and the oil temperature")
    frags = []
    frags.append(pump.build(g, "pump"))
    relief_valve.build(g, "relief", "pump.out")
    valve = directional_valve.build(g, "valve")
    supply = fixed_drop.build(g, "supply_line", "pump.out", valve.ports["P"])
    hose_a = hose.build(g, "hose_A", valve.ports["A"])
    hose_b = hose.build(g, "hose_B", valve.ports["B"])
    check_valve.build(g, "check", hose_a.ports["line"])
    cyl = cylinder.build(g, "cylinder")
    g.connect(hose_a.ports["line"], cyl.ports["1"])
    g.connect(hose_b.ports["line"], cyl.ports["2"])
    load.build(g, "load", cyl.ports["rod"], hose_b.ports["line"])
    throttle.build(g, "throttle_H", cyl.ports["1"], cyl.ports["2"])
    throttle.build(g, "throttle_I", valve.ports["P"], valve.ports["T"])
    frags += [hose_a, hose_b, cyl]
    g.output("Q_meter_B", f"flow:{supply.ports['line']}", "m^3/s",
             "flowmeter B: flow into the valve's P port")
    g.output("Q_meter_C", LawCall(negated, (f"flow:{hose_b.ports['line']}",)), "m^3/s",
             "flowmeter C: flow out of chamber 2 towards port B")
    g.output("Q_throttle_H", "flow:throttle_H.path", "m^3/s", "bypass through throttle H")
    g.output("Q_throttle_I", "flow:throttle_I.path", "m^3/s", "bypass through throttle I")
    return g, [f.derive for f in frags if f.derive is not None]


@dataclass
class Rig:
    """A rig ready to simulate: its spec, compiled model and parameter derivations."""

    spec: RigSpec
    model: CompiledModel
    derivations: list[Derivation]
    fluid: Fluid
    base: dict[str, float] = field(default_factory=dict)

    @classmethod
    def from_spec(cls, spec: RigSpec) -> Rig:
        """Compile the circuit and keep the rig's parameter values."""
        _, derivations = _graph_cached()
        model = _model_cached()
        fl = Fluid(**{k: q.value for k, q in spec.fluid.items()})
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

    def values(self, overrides: Mapping[str, float] | None = None,
               condition: Condition | None = None) -> dict[str, float]:
        """All graph parameter values for ``overrides`` (``role.name`` → SI) and ``condition``."""
        cond = condition if condition is not None else self.default_condition()
        v = dict(self.base)
        for key, value in (overrides or {}).items():
            role, _, pname = key.partition(".")
            if role not in CIRCUIT_ROLES or pname not in {
                    p.name for p in COMPONENT_TYPES[CIRCUIT_ROLES[role]].PARAMETERS}:
                raise ParameterError(f"unknown parameter {key!r} (use role.name, e.g. "
                                     "'cylinder.cc')", field=f"overrides.{key}")
            decl = next(p for p in COMPONENT_TYPES[CIRCUIT_ROLES[role]].PARAMETERS
                        if p.name == pname)
            try:
                check_bounds(float(value), decl, f"overrides.{key}")
            except ParameterError as exc:
                raise ParameterError(exc.message, field=exc.field) from None
            v[key] = float(value)
        for decl in CONDITION_PARAMETERS:
            val = {"force": cond.load, "back_pressure": cond.back_pressure,
                   "oil_temperature": cond.oil_temperature}[decl.name]
            try:
                check_bounds(val, decl, f"condition.{decl.name}")
            except ParameterError as exc:
                raise ParameterError(exc.message, field=exc.field) from None
        if cond.pump_speed is not None:
            if not cond.pump_speed > 0:
                raise ParameterError("pump speed must be > 0 rad/s", field="condition.pump_speed")
            v["pump.speed"] = cond.pump_speed
        v["load.force"] = cond.load
        v["load.back_pressure"] = cond.back_pressure
        T = cond.oil_temperature
        v["fluid.mu"] = self.fluid.dynamic_viscosity(T)
        v["fluid.rho"] = self.fluid.density(T)
        v["fluid.beta"] = self.fluid.beta
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


_CACHE: dict[str, object] = {}
#: the circuit is built and compiled once per process, even under concurrent first calls
_CACHE_LOCK = threading.Lock()


def _graph_cached() -> tuple[BondGraph, list[Derivation]]:
    with _CACHE_LOCK:
        if "graph" not in _CACHE:
            _CACHE["graph"] = build_graph("pump-valve-cylinder")
        g = _CACHE["graph"]
    assert isinstance(g, tuple)
    return g


def _model_cached() -> CompiledModel:
    graph = _graph_cached()[0]
    with _CACHE_LOCK:
        if "model" not in _CACHE:
            _CACHE["model"] = compile_graph(graph)
        m = _CACHE["model"]
    assert isinstance(m, CompiledModel)
    return m
