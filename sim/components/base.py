"""What every component module shares: declaring its parameters on a graph, and fragments."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from sim.bondgraph.graph import BondGraph
from sim.params import Param

__all__ = ["Derivation", "Fragment", "declare"]

#: computes derived graph parameters from all graph parameter values (by full name)
Derivation = Callable[[Mapping[str, float]], dict[str, float]]


@dataclass
class Fragment:
    """What a component added to a graph.

    Attributes
    ----------
    name
        Instance name (prefix of its elements and parameters).
    ports
        Port name → junction name in the graph.
    derive
        Computes the component's derived parameters (areas, hose R/C/I, viscosity-
        dependent values) from the full parameter mapping; ``None`` if it has none.
    """

    name: str
    ports: dict[str, str]
    derive: Derivation | None = None
    outputs: list[str] = field(default_factory=list)


def declare(g: BondGraph, prefix: str, params: tuple[Param, ...],
            values: Mapping[str, float] | None = None) -> None:
    """Declare ``prefix.name`` for each parameter, with ``values`` overriding defaults."""
    values = values or {}
    for p in params:
        g.parameter(f"{prefix}.{p.name}", values.get(p.name, p.default), p.unit, p.source)
