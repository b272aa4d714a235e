"""The bond graph: elements joined by bonds, parameters, auxiliary states and outputs."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass

from sim.bondgraph.elements import Element, Kind, LawCall
from sim.errors import ModelStructureError, ParameterError

__all__ = ["Bond", "BondGraph", "Integrator", "Output", "ParamValue", "Table"]

_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.]*$")


@dataclass(frozen=True)
class Bond:
    """A power bond from ``src`` to ``dst`` (the half-arrow points at ``dst``)."""

    index: int
    src: str
    dst: str
    label: str = ""

    def other(self, name: str) -> str:
        """The element at the other end from ``name``."""
        return self.dst if name == self.src else self.src

    def sign_at(self, name: str) -> int:
        """+1 if the bond points into ``name``, −1 if it leaves it."""
        return 1 if self.dst == name else -1


@dataclass
class ParamValue:
    """A graph parameter: value [unit] and where it comes from."""

    name: str
    value: float
    unit: str = ""
    source: str = ""


@dataclass(frozen=True)
class Integrator:
    """An auxiliary state ``x`` with ``dx/dt = signal`` (e.g. piston position from velocity)."""

    name: str
    signal: str | LawCall
    initial: str
    scale: float
    unit: str


@dataclass(frozen=True)
class Table:
    """A tabulated input signal: a block of ``2·size`` entries of the parameter vector.

    Layout of the block: ``size`` sample times [s], non-decreasing, then the ``size``
    values [unit] (see :func:`sim.bondgraph.laws.table_lookup` for the interpolation and
    :meth:`sim.bondgraph.CompiledModel.params` for how a series fills the block).
    """

    name: str
    size: int
    value: float
    unit: str
    source: str


@dataclass(frozen=True)
class Output:
    """A named output signal: a reference or a law call, with its unit."""

    name: str
    expr: str | LawCall
    unit: str
    description: str = ""


class BondGraph:
    """A bond graph under construction.

    Components add their fragments with :meth:`add` and :meth:`connect`; parameters are
    declared with :meth:`parameter`.  :func:`sim.bondgraph.compile_graph` turns the graph
    into compiled state equations.
    """

    def __init__(self, name: str = "graph") -> None:
        self.name = name
        self.elements: dict[str, Element] = {}
        self.bonds: list[Bond] = []
        self.parameters: dict[str, ParamValue] = {}
        self.integrators: dict[str, Integrator] = {}
        self.outputs: dict[str, Output] = {}
        self.tables: dict[str, Table] = {}

    # -- construction -------------------------------------------------------------
    def add(self, element: Element) -> str:
        """Add an element; returns its name."""
        if not _NAME.match(element.name):
            raise ModelStructureError(f"invalid element name {element.name!r}",
                                      elements=(element.name,))
        if element.name in self.elements:
            raise ModelStructureError(f"duplicate element {element.name!r}",
                                      elements=(element.name,))
        self.elements[element.name] = element
        return element.name

    def connect(self, src: str, dst: str, label: str = "") -> Bond:
        """Join ``src`` → ``dst`` with a bond (power positive from src to dst)."""
        for n in (src, dst):
            if n not in self.elements:
                raise ModelStructureError(f"bond to unknown element {n!r}", elements=(n,))
        if src == dst:
            raise ModelStructureError(f"bond from {src!r} to itself", elements=(src,))
        if label and any(b.label == label for b in self.bonds):
            raise ModelStructureError(f"duplicate bond label {label!r}", elements=(src, dst))
        bond = Bond(len(self.bonds), src, dst, label)
        self.bonds.append(bond)
        return bond

    def parameter(self, name: str, value: float, unit: str = "", source: str = "") -> str:
        """Declare (or redefine) a parameter; returns the reference ``"p:name"``."""
        if not _NAME.match(name):
            raise ParameterError(f"invalid parameter name {name!r}", field=name)
        self.parameters[name] = ParamValue(name, float(value), unit, source)
        return f"p:{name}"

    def table(self, name: str, size: int, *, value: float = 0.0, unit: str = "",
              source: str = "") -> str:
        """Reserve a tabulated input signal of ``size`` points; returns ``"tbl:name"``.

        The reference is a *law argument*: the equation builder expands it into the three
        arguments ``p, OFFSET, SIZE`` (parameter vector, start of the block, number of
        points) that :func:`sim.bondgraph.laws.table_lookup` takes.  The block sits after
        the named parameters, in the order the tables are declared.

        Parameters
        ----------
        name
            Table name (same rules as element names).
        size
            Number of points ≥ 1 (fixed in the compiled code; a longer or shorter series
            is fitted to it when the parameter vector is filled).
        value
            Default signal: the constant ``value`` [unit].
        unit, source
            Unit of the values and where the signal comes from.
        """
        if not _NAME.match(name):
            raise ParameterError(f"invalid table name {name!r}", field=name)
        if name in self.tables:
            raise ModelStructureError(f"duplicate table {name!r}", elements=(name,))
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise ParameterError(f"table {name!r}: size must be an integer ≥ 1", field=name)
        self.tables[name] = Table(name, size, float(value), unit, source)
        return f"tbl:{name}"

    def integrate(self, name: str, signal: str | LawCall, *, initial: str = "0.0",
                  scale: float = 1.0, unit: str = "") -> str:
        """Add the auxiliary state ``name`` with ``d(name)/dt = signal``; returns ``"x:name"``.

        ``signal`` is a reference (``"flow:hose2.line"``) or a law of efforts, flows, states
        and parameters (:func:`~sim.bondgraph.call`), e.g. a first-order lag
        ``call(rate, "effort:pump.core", "x:name", "p:tau")`` reading its own state.
        """
        if name in self.integrators:
            raise ModelStructureError(f"duplicate auxiliary state {name!r}", elements=(name,))
        self.integrators[name] = Integrator(name, signal, initial, scale, unit)
        return f"x:{name}"

    def output(self, name: str, expr: str | LawCall, unit: str, description: str = "") -> None:
        """Declare an output signal to be recorded in time series and summaries."""
        self.outputs[name] = Output(name, expr, unit, description)

    # -- queries ------------------------------------------------------------------
    def bonds_of(self, name: str) -> list[Bond]:
        """Bonds attached to element ``name``, in creation order."""
        return [b for b in self.bonds if name in (b.src, b.dst)]

    def by_kind(self, *kinds: Kind) -> Iterator[Element]:
        """Elements of the given kinds, in insertion order."""
        return (e for e in self.elements.values() if e.kind in kinds)

    def check(self) -> None:
        """Validate the structure: port counts and two-port orientation.

        Raises
        ------
        ModelStructureError
            Naming the offending element.
        """
        for el in self.elements.values():
            bonds = self.bonds_of(el.name)
            ports = el.kind.ports
            if ports is None:
                if not bonds:
                    raise ModelStructureError(f"junction {el.name!r} has no bonds",
                                              elements=(el.name,))
            elif len(bonds) != ports:
                raise ModelStructureError(
                    f"{el.kind} {el.name!r} needs {ports} bond(s), has {len(bonds)}",
                    elements=(el.name,))
            if ports == 2:
                ins = [b for b in bonds if b.dst == el.name]
                if len(ins) != 1:
                    raise ModelStructureError(
                        f"{el.kind} {el.name!r} needs one bond in and one bond out",
                        elements=(el.name,))
        for b in self.bonds:
            for n in (b.src, b.dst):
                el = self.elements[n]
                if el.kind in (Kind.C, Kind.I, Kind.R) and b.dst != n:
                    raise ModelStructureError(
                        f"the bond of {el.kind} {n!r} must point into it (power absorbed)",
                        elements=(n,))
                if el.kind in (Kind.SE, Kind.SF, Kind.MSE, Kind.MSF) and b.src != n:
                    raise ModelStructureError(
                        f"the bond of source {n!r} must point out of it", elements=(n,))

    def two_port_bonds(self, name: str) -> tuple[Bond, Bond]:
        """(bond in, bond out) of a two-port element."""
        bonds = self.bonds_of(name)
        b_in = next(b for b in bonds if b.dst == name)
        b_out = next(b for b in bonds if b.src == name)
        return b_in, b_out
