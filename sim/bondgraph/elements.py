"""Bond-graph elements and the references their constitutive laws take.

An element is data: its kind, its name and the law(s) that relate its port variables.
A law is a compiled scalar function (:func:`sim.bondgraph.laws.law`) called with a tuple
of *references*, strings that the equation generator resolves:

==================  =====================================================================
reference           meaning
==================  =====================================================================
``"e"``, ``"f"``    effort / flow on the element's own bond (R laws)
``"p:NAME"``        the graph parameter ``NAME`` (see :meth:`BondGraph.parameter`)
``"effort:J"``      the common effort of 0-junction ``J``
``"flow:J"``        the common flow of 1-junction ``J``
``"e:B"``, ``"f:B"``  effort / flow of the bond labelled ``B``
``"x:NAME"``        the auxiliary state ``NAME`` (an integrated signal, e.g. piston position)
``"tbl:NAME"``      the tabulated signal ``NAME`` (:meth:`BondGraph.table`); law arguments
                    only: expands to the three arguments ``p, OFFSET, SIZE``
``"t"``             time [s]
``"1.5"``           a numeric literal
==================  =====================================================================

Storage elements use co-energy states: a C integrates its effort, ``de/dt = f / C(...)``,
and an I its flow, ``df/dt = e / I(...)``.  For a constant C or I this is the textbook
form; for a hydraulic chamber whose capacitance ``V(x)/β`` changes with the piston
position it is the physically right one, ``dP/dt = β/V · Q_net``, because the flow the
moving piston displaces (``A·ẋ``) reaches the 0-junction through the TF.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

__all__ = [
    "GY",
    "MGY",
    "MTF",
    "TF",
    "C",
    "Element",
    "I",
    "Kind",
    "LawCall",
    "MSe",
    "MSf",
    "One",
    "R",
    "Se",
    "Sf",
    "Zero",
    "call",
]


class Kind(StrEnum):
    """Element kinds of the bond-graph language."""

    SE = "Se"
    SF = "Sf"
    MSE = "MSe"
    MSF = "MSf"
    C = "C"
    I = "I"
    R = "R"
    TF = "TF"
    MTF = "MTF"
    GY = "GY"
    MGY = "MGY"
    ZERO = "0"
    ONE = "1"

    @property
    def ports(self) -> int | None:
        """Number of bonds the kind takes (``None``: any number ≥ 1)."""
        if self in (Kind.ZERO, Kind.ONE):
            return None
        if self in (Kind.TF, Kind.MTF, Kind.GY, Kind.MGY):
            return 2
        return 1


SOURCES = (Kind.SE, Kind.SF, Kind.MSE, Kind.MSF)
STORAGES = (Kind.C, Kind.I)
TWO_PORTS_TF = (Kind.TF, Kind.MTF)
TWO_PORTS_GY = (Kind.GY, Kind.MGY)


@dataclass(frozen=True)
class LawCall:
    """A compiled law and the references of its arguments."""

    func: Callable[..., Any]
    args: tuple[str, ...]

    def describe(self) -> str:
        """Human-readable ``name(arg, ...)``."""
        return f"{_law_name(self.func)}({', '.join(self.args)})"


def _law_name(func: Callable[..., Any]) -> str:
    return str(getattr(func, "__name__", repr(func)))


@dataclass
class Element:
    """One bond-graph element.

    Attributes
    ----------
    name
        Unique name in the graph.
    kind
        Element kind.
    law
        Sources: the effort or flow; C: the capacitance; I: the inertance;
        TF/MTF: the modulus ``m`` with ``e_in = m·e_out`` and ``f_out = m·f_in``;
        GY/MGY: the ratio ``r`` with ``e_in = r·f_out`` and ``e_out = r·f_in``.
    flow_law
        R only: flow as a function of effort (first reference usually ``"e"``).
    effort_law
        R only: effort as a function of flow.
    initial
        C/I only: reference of the initial state (``"p:NAME"`` or a literal).
    scale
        C/I only: typical magnitude of the state, for error control and Newton scaling.
    description
        Free text shown in exports.
    """

    name: str
    kind: Kind
    law: LawCall | None = None
    flow_law: LawCall | None = None
    effort_law: LawCall | None = None
    initial: str = "0.0"
    scale: float = 1.0
    description: str = ""
    meta: dict[str, str] = field(default_factory=dict)


def _call(func: Callable[..., Any], *args: str) -> LawCall:
    return LawCall(func, tuple(args))


def Se(name: str, func: Callable[..., Any], *args: str, description: str = "") -> Element:
    """Effort source (effort = ``func(*args)``; constant in the parameters)."""
    return Element(name, Kind.SE, law=_call(func, *args), description=description)


def Sf(name: str, func: Callable[..., Any], *args: str, description: str = "") -> Element:
    """Flow source."""
    return Element(name, Kind.SF, law=_call(func, *args), description=description)


def MSe(name: str, func: Callable[..., Any], *args: str, description: str = "") -> Element:
    """Modulated effort source (its law reads signals of the graph)."""
    return Element(name, Kind.MSE, law=_call(func, *args), description=description)


def MSf(name: str, func: Callable[..., Any], *args: str, description: str = "") -> Element:
    """Modulated flow source."""
    return Element(name, Kind.MSF, law=_call(func, *args), description=description)


def C(name: str, func: Callable[..., Any], *args: str, initial: str = "0.0",
      scale: float = 1.0, description: str = "") -> Element:
    """Capacitance (state: its effort; ``de/dt = f / func(*args)``)."""
    return Element(name, Kind.C, law=_call(func, *args), initial=initial, scale=scale,
                   description=description)


def I(name: str, func: Callable[..., Any], *args: str, initial: str = "0.0",
      scale: float = 1.0, description: str = "") -> Element:
    """Inertance (state: its flow; ``df/dt = e / func(*args)``)."""
    return Element(name, Kind.I, law=_call(func, *args), initial=initial, scale=scale,
                   description=description)


def R(name: str, *, flow: LawCall | None = None, effort: LawCall | None = None,
      description: str = "") -> Element:
    """Resistance with a flow-out law, an effort-out law, or both."""
    if flow is None and effort is None:
        raise ValueError(f"R {name!r} needs a flow law or an effort law")
    return Element(name, Kind.R, flow_law=flow, effort_law=effort, description=description)


def TF(name: str, func: Callable[..., Any], *args: str, description: str = "") -> Element:
    """Transformer: ``e_in = m·e_out``, ``f_out = m·f_in`` with ``m = func(*args)``."""
    return Element(name, Kind.TF, law=_call(func, *args), description=description)


def MTF(name: str, func: Callable[..., Any], *args: str, description: str = "") -> Element:
    """Modulated transformer."""
    return Element(name, Kind.MTF, law=_call(func, *args), description=description)


def GY(name: str, func: Callable[..., Any], *args: str, description: str = "") -> Element:
    """Gyrator: ``e_in = r·f_out``, ``e_out = r·f_in`` with ``r = func(*args)``."""
    return Element(name, Kind.GY, law=_call(func, *args), description=description)


def MGY(name: str, func: Callable[..., Any], *args: str, description: str = "") -> Element:
    """Modulated gyrator."""
    return Element(name, Kind.MGY, law=_call(func, *args), description=description)


def Zero(name: str, description: str = "") -> Element:
    """0-junction: common effort, flows sum to zero."""
    return Element(name, Kind.ZERO, description=description)


def One(name: str, description: str = "") -> Element:
    """1-junction: common flow, efforts sum to zero."""
    return Element(name, Kind.ONE, description=description)


def call(func: Callable[..., Any], *args: str) -> LawCall:
    """Build a :class:`LawCall` (for R laws): ``call(path_flow, "e", "p:K", ...)``."""
    return _call(func, *args)
