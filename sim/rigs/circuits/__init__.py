"""Circuits a rig file can name: the roles each takes and how its bond graph is built.

A rig file says ``circuit: NAME``; the circuit fixes which *roles* the file must fill
(``pump``, ``valve`` ...), the component type each role takes, the bond graph that joins
them, and how an operating condition reaches the graph's parameters.  A new circuit is a
module that builds its graph and calls :func:`register`; the rig schema, the assembly and
the store then handle it like the paper-002 circuit.

Registered here:

* ``pump-valve-cylinder`` — paper 002, Figure 1 (:mod:`sim.rigs.circuits.pump_valve_cylinder`);
* ``pump-relief-orifice`` — the ZeMA rig at its data's level (:mod:`sim.rigs.circuits.pump_relief_orifice`).

Only a circuit with paper 002's working/return cycle (:attr:`Circuit.cycle`) runs the cycle
simulation, the diagnosis and commissioning; for another, those raise
:class:`~sim.errors.CircuitError` (:func:`require_cycle`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType, ModuleType

from sim.bondgraph import BondGraph
from sim.components import (
    check_valve,
    cylinder,
    directional_valve,
    fixed_drop,
    hose,
    pump,
    relief_valve,
    throttle,
)
from sim.components.base import Derivation
from sim.errors import CircuitError, RigFileError
from sim.params import Param, Relation

__all__ = ["CIRCUITS", "COMPONENT_TYPES", "DEFAULT_CIRCUIT", "Circuit", "get_circuit", "register",
           "require_cycle"]

#: component type name → module declaring ``PARAMETERS`` (the types a rig file may use)
COMPONENT_TYPES: dict[str, ModuleType] = {
    "fixed_displacement_pump": pump,
    "relief_valve": relief_valve,
    "fixed_drop_line": fixed_drop,
    "directional_valve_4_2": directional_valve,
    "hose": hose,
    "check_valve": check_valve,
    "double_acting_cylinder": cylinder,
    "throttle_valve": throttle,
}

#: builds the circuit's bond graph (named ``name``) and its parameter derivations
GraphBuilder = Callable[[str], tuple[BondGraph, list[Derivation]]]


@dataclass(frozen=True)
class Circuit:
    """A circuit a rig file can name.

    Attributes
    ----------
    name
        Identifier written in rig files (``"pump-valve-cylinder"``).
    title
        One line for humans, with the paper it comes from.
    roles
        Role → component type (a key of :data:`COMPONENT_TYPES`), in file order.
    build
        Builds the bond graph with default parameters and returns it with the
        components' parameter derivations.
    condition
        Operating-condition parameters a rig file may state as defaults (``condition:``
        block), each with unit, default, source and bounds.
    condition_targets
        Attribute of :class:`sim.rigs.Condition` → graph parameter it sets
        (``{"load": "load.force"}``).  The oil temperature always sets the fluid's
        properties and ``pump_speed`` sets ``pump.speed``.
    cycle
        Whether the circuit has paper 002's working/return cycle — a double-acting
        cylinder driven through the 4/2 valve — which the cycle simulation
        (:func:`sim.cycle.run_cycle`, :func:`sim.steady.steady_cycle`), the diagnosis
        and commissioning run; a circuit without it is simulated and checked through
        its bond graph and the steady pump-bench workflow only.
    """

    name: str
    title: str
    roles: Mapping[str, str]
    build: GraphBuilder
    condition: tuple[Param, ...]
    condition_targets: Mapping[str, str]
    cycle: bool = False

    def parameter(self, role: str, name: str) -> Param | None:
        """The declaration of ``role.name`` in this circuit, or ``None``."""
        ctype = self.roles.get(role)
        if ctype is None:
            return None
        return next((p for p in COMPONENT_TYPES[ctype].PARAMETERS if p.name == name), None)

    def relations(self, role: str) -> tuple[Relation, ...]:
        """The geometric bounds among the parameters of ``role``'s component (none for an
        unknown role or a component without them)."""
        ctype = self.roles.get(role)
        return () if ctype is None else getattr(COMPONENT_TYPES[ctype], "RELATIONS", ())


_REGISTRY: dict[str, Circuit] = {}
#: read-only view of the registered circuits, by name
CIRCUITS: Mapping[str, Circuit] = MappingProxyType(_REGISTRY)


def require_cycle(circuit: Circuit, rig_name: str, what: str) -> None:
    """Raise :class:`CircuitError` (``field="rig_id"``) unless ``circuit`` has the
    cylinder's working/return cycle that ``what`` runs (:attr:`Circuit.cycle`); the message
    names the rig, its circuit and the circuits that have one."""
    if not circuit.cycle:
        cycles = [c.name for c in _REGISTRY.values() if c.cycle]
        raise CircuitError(
            f"{what} needs the working/return cycle of a cylinder; rig {rig_name!r} is a "
            f"{circuit.name!r} circuit without one (circuits with it: {', '.join(cycles)}). "
            "Its pump can be checked against steady test points with the discrepancy "
            "workflow (a pump-bench table).", field="rig_id")


def register(circuit: Circuit) -> Circuit:
    """Register ``circuit`` (its component types must be known); returns it."""
    for role, ctype in circuit.roles.items():
        if ctype not in COMPONENT_TYPES:
            raise ValueError(f"circuit {circuit.name!r}: role {role!r} has unknown type {ctype!r}")
    if circuit.name in _REGISTRY and _REGISTRY[circuit.name] is not circuit:
        raise ValueError(f"circuit {circuit.name!r} is registered twice")
    _REGISTRY[circuit.name] = circuit
    return circuit


def get_circuit(name: object) -> Circuit:
    """The registered circuit ``name``.

    Raises
    ------
    RigFileError
        Unknown circuit (``field="circuit"``), listing the known ones.
    """
    circuit = _REGISTRY.get(name) if isinstance(name, str) else None
    if circuit is None:
        raise RigFileError(f"unknown circuit {name!r} (known: {', '.join(_REGISTRY)})",
                           field="circuit")
    return circuit


#: the circuit of a rig file that names none
DEFAULT_CIRCUIT = "pump-valve-cylinder"

# the circuits shipped with hydrodiag register themselves on import
from sim.rigs.circuits import (  # noqa: E402
    pump_relief_orifice,  # noqa: F401
    pump_valve_cylinder,  # noqa: F401
)
