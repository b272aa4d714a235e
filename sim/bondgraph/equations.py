"""Causal equations of a bond graph, sorted for evaluation.

After causality assignment every bond variable has exactly one defining equation, given
by the element that imposes it.  Storage states, parameters and time are the inputs;
the equations are sorted topologically so that each variable is computed after those it
needs.  A cycle in that order is an algebraic loop, reported with the elements whose
equations form it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from sim.bondgraph.causality import assign_causality
from sim.bondgraph.elements import STORAGES, TWO_PORTS_GY, TWO_PORTS_TF, Element, Kind, LawCall
from sim.bondgraph.graph import BondGraph
from sim.errors import AlgebraicLoopError, ModelStructureError

__all__ = ["Equation", "EquationSystem", "State", "derive_equations"]


@dataclass(frozen=True)
class State:
    """A state variable of the compiled system."""

    name: str
    kind: str  # "C", "I" or "aux"
    element: str
    initial: str
    scale: float
    unit: str = ""


@dataclass
class Equation:
    """``target = code`` with the variables it needs and the element that owns it."""

    target: str
    code: str
    deps: frozenset[str]
    element: str
    text: str


@dataclass
class EquationSystem:
    """Everything the code generator needs."""

    graph: BondGraph
    setter: list[str]
    states: list[State]
    params: list[str]
    equations: list[Equation]
    derivatives: list[tuple[str, str]]  # (state name, code)
    outputs: list[tuple[str, str, str]]  # (name, code, unit)
    laws: dict[str, Callable[..., Any]] = field(default_factory=dict)
    #: table name → (offset of its block in the parameter vector, number of points)
    tables: dict[str, tuple[int, int]] = field(default_factory=dict)

    def describe(self) -> str:
        """The equations as text, in evaluation order, for checking against a drawing."""
        lines = [f"# bond graph {self.graph.name!r}: {len(self.states)} states, "
                 f"{len(self.graph.bonds)} bonds"]
        lines += [f"# b{b.index}: {b.src} → {b.dst}{f' ({b.label})' if b.label else ''}, "
                  f"effort set by {self.setter[b.index]}" for b in self.graph.bonds]
        lines += [f"{eq.text}    # {eq.element}" for eq in self.equations]
        for (name, code), st in zip(self.derivatives, self.states, strict=True):
            lines.append(f"d{name}/dt = {_pretty(code, self)}    # {st.element}")
        return "\n".join(lines)


def _pretty(code: str, system: EquationSystem) -> str:
    out = code
    for i, st in reversed(list(enumerate(system.states))):
        out = out.replace(f"y[{i}]", st.name)
    for i, p in reversed(list(enumerate(system.params))):
        out = out.replace(f"p[{i}]", p)
    return out


class _Builder:
    def __init__(self, graph: BondGraph) -> None:
        self.g = graph
        self.setter = assign_causality(graph)
        self.params = list(graph.parameters)
        self.pindex = {p: i for i, p in enumerate(self.params)}
        self.tables: dict[str, tuple[int, int]] = {}
        offset = len(self.params)
        for tbl in graph.tables.values():  # blocks after the named parameters
            self.tables[tbl.name] = (offset, tbl.size)
            offset += 2 * tbl.size
        self.states: list[State] = []
        self.sindex: dict[str, int] = {}
        self.laws: dict[str, Callable[..., Any]] = {}
        self.eqs: dict[str, Equation] = {}

    # -- references -----------------------------------------------------------------
    def ref(self, token: str, own: int | None, element: str) -> tuple[str, set[str]]:
        token = token.strip()
        if own is not None and token in ("e", "f"):
            v = f"{token}_{own}"
            return v, {v}
        if token == "t":
            return "t", set()
        kind, _, name = token.partition(":")
        if kind == "p":
            if name not in self.pindex:
                raise ModelStructureError(f"{element!r} refers to unknown parameter {name!r}",
                                          elements=(element,))
            return f"p[{self.pindex[name]}]", set()
        if kind == "tbl":
            raise ModelStructureError(
                f"{element!r}: the table reference {token!r} is a law argument (it expands "
                "to p, OFFSET, SIZE); read the table with a law such as table_lookup",
                elements=(element,))
        if kind == "x":
            if name not in self.sindex:
                raise ModelStructureError(f"{element!r} refers to unknown state {name!r}",
                                          elements=(element,))
            return f"y[{self.sindex[name]}]", set()
        if kind in ("effort", "flow"):
            v = self.junction_var(kind, name, element)
            return v, {v}
        if kind in ("e", "f"):
            matches = [b for b in self.g.bonds if b.label == name]
            if not matches:
                raise ModelStructureError(f"{element!r} refers to unknown bond {name!r}",
                                          elements=(element,))
            v = f"{kind}_{matches[0].index}"
            return v, {v}
        try:
            return repr(float(token)), set()
        except ValueError:
            raise ModelStructureError(f"{element!r}: cannot read reference {token!r}",
                                      elements=(element,)) from None

    def junction_var(self, kind: str, name: str, element: str) -> str:
        el = self.g.elements.get(name)
        if el is None:
            raise ModelStructureError(f"{element!r} refers to unknown element {name!r}",
                                      elements=(element,))
        bonds = self.g.bonds_of(name)
        if (kind == "effort" and el.kind is Kind.ZERO) or (kind == "flow" and el.kind is Kind.ONE):
            return f"{kind[0]}_{bonds[0].index}"
        if len(bonds) == 1:
            return f"{kind[0]}_{bonds[0].index}"
        raise ModelStructureError(
            f"{element!r} asks for the {kind} of {name!r}, which has no single {kind}",
            elements=(element, name))

    def call(self, law: LawCall, own: int | None, element: str) -> tuple[str, set[str]]:
        lname = f"law_{getattr(law.func, '__name__', 'f')}"
        prev = self.laws.get(lname)
        if prev is not None and prev is not law.func:
            lname = f"{lname}_{len(self.laws)}"
        self.laws[lname] = law.func
        args, deps = [], set()
        for a in law.args:
            kind, _, name = a.strip().partition(":")
            if kind == "tbl":
                if name not in self.tables:
                    raise ModelStructureError(f"{element!r} refers to unknown table {name!r}",
                                              elements=(element,))
                offset, size = self.tables[name]
                args.append(f"p, {offset}, {size}")
                continue
            code, d = self.ref(a, own, element)
            args.append(code)
            deps |= d
        return f"{lname}({', '.join(args)})", deps

    def add(self, target: str, code: str, deps: set[str], element: str, text: str) -> None:
        if target in self.eqs:
            raise ModelStructureError(f"{target} defined twice ({self.eqs[target].element}, "
                                      f"{element})", elements=(self.eqs[target].element, element))
        self.eqs[target] = Equation(target, code, frozenset(deps), element, text)

    # -- build ----------------------------------------------------------------------
    def build(self) -> EquationSystem:
        g = self.g
        for el in g.by_kind(*STORAGES):
            self.sindex[el.name] = len(self.states)
            self.states.append(State(el.name, str(el.kind), el.name, el.initial, el.scale))
        for aux in g.integrators.values():
            self.sindex[aux.name] = len(self.states)
            self.states.append(State(aux.name, "aux", aux.name, aux.initial, aux.scale, aux.unit))
        derivs: list[tuple[str, str]] = []
        for el in g.elements.values():
            self.element_equations(el, derivs)
        for aux in g.integrators.values():
            if isinstance(aux.signal, LawCall):
                code, _ = self.call(aux.signal, None, aux.name)
            else:
                code, _ = self.ref(aux.signal, None, aux.name)
            derivs.append((aux.name, code))
        outputs = []
        for out in g.outputs.values():
            if isinstance(out.expr, LawCall):
                code, _ = self.call(out.expr, None, out.name)
            else:
                code, _ = self.ref(out.expr, None, out.name)
            outputs.append((out.name, code, out.unit))
        order = self.sort()
        # derivatives ordered like the states
        dmap = dict(derivs)
        derivatives = [(s.name, dmap[s.name]) for s in self.states]
        return EquationSystem(g, self.setter, self.states, self.params, order, derivatives,
                              outputs, self.laws, self.tables)

    def element_equations(self, el: Element, derivs: list[tuple[str, str]]) -> None:
        g, n = self.g, el.name
        bonds = g.bonds_of(n)
        k = el.kind
        if k in (Kind.SE, Kind.MSE, Kind.SF, Kind.MSF):
            (b,) = bonds
            var = f"e_{b.index}" if k in (Kind.SE, Kind.MSE) else f"f_{b.index}"
            assert el.law is not None
            code, deps = self.call(el.law, b.index, n)
            self.add(var, code, deps, n, f"{var} = {el.law.describe()}")
        elif k in STORAGES:
            (b,) = bonds
            i = self.sindex[n]
            assert el.law is not None
            code, _ = self.call(el.law, b.index, n)
            if k is Kind.C:
                self.add(f"e_{b.index}", f"y[{i}]", set(), n, f"e_{b.index} = {n} (state)")
                derivs.append((n, f"f_{b.index} / {code}"))
            else:
                self.add(f"f_{b.index}", f"y[{i}]", set(), n, f"f_{b.index} = {n} (state)")
                derivs.append((n, f"e_{b.index} / {code}"))
        elif k is Kind.R:
            (b,) = bonds
            effort_out = self.setter[b.index] == n
            law = el.effort_law if effort_out else el.flow_law
            assert law is not None
            code, deps = self.call(law, b.index, n)
            var = f"e_{b.index}" if effort_out else f"f_{b.index}"
            self.add(var, code, deps, n, f"{var} = {law.describe()}")
        elif k in TWO_PORTS_TF:
            b1, b2 = g.two_port_bonds(n)
            assert el.law is not None
            m, mdeps = self.call(el.law, None, n)
            i1, i2 = b1.index, b2.index
            if self.setter[i1] == n:  # TF gives e1 and f2
                self.add(f"e_{i1}", f"({m}) * e_{i2}", mdeps | {f"e_{i2}"}, n,
                         f"e_{i1} = m·e_{i2}, m = {el.law.describe()}")
                self.add(f"f_{i2}", f"({m}) * f_{i1}", mdeps | {f"f_{i1}"}, n,
                         f"f_{i2} = m·f_{i1}")
            else:  # TF gives e2 and f1
                self.add(f"e_{i2}", f"e_{i1} / ({m})", mdeps | {f"e_{i1}"}, n,
                         f"e_{i2} = e_{i1}/m, m = {el.law.describe()}")
                self.add(f"f_{i1}", f"f_{i2} / ({m})", mdeps | {f"f_{i2}"}, n,
                         f"f_{i1} = f_{i2}/m")
        elif k in TWO_PORTS_GY:
            b1, b2 = g.two_port_bonds(n)
            assert el.law is not None
            r, rdeps = self.call(el.law, None, n)
            i1, i2 = b1.index, b2.index
            if self.setter[i1] == n:  # GY gives both efforts
                self.add(f"e_{i1}", f"({r}) * f_{i2}", rdeps | {f"f_{i2}"}, n,
                         f"e_{i1} = r·f_{i2}, r = {el.law.describe()}")
                self.add(f"e_{i2}", f"({r}) * f_{i1}", rdeps | {f"f_{i1}"}, n,
                         f"e_{i2} = r·f_{i1}")
            else:  # GY gives both flows
                self.add(f"f_{i2}", f"e_{i1} / ({r})", rdeps | {f"e_{i1}"}, n,
                         f"f_{i2} = e_{i1}/r, r = {el.law.describe()}")
                self.add(f"f_{i1}", f"e_{i2} / ({r})", rdeps | {f"e_{i2}"}, n,
                         f"f_{i1} = e_{i2}/r")
        elif k in (Kind.ZERO, Kind.ONE):
            common, summed = ("e", "f") if k is Kind.ZERO else ("f", "e")
            if k is Kind.ZERO:
                strong = next(b for b in bonds if self.setter[b.index] != n)
            else:
                strong = next(b for b in bonds if self.setter[b.index] == n)
            others = [b for b in bonds if b is not strong]
            for b in others:
                self.add(f"{common}_{b.index}", f"{common}_{strong.index}",
                         {f"{common}_{strong.index}"}, n,
                         f"{common}_{b.index} = {common}_{strong.index}")
            s0 = strong.sign_at(n)
            terms = [f"{'+' if -s0 * b.sign_at(n) > 0 else '-'} {summed}_{b.index}"
                     for b in others]
            code = " ".join(terms).lstrip("+ ") if terms else "0.0"
            if code.startswith("- "):
                code = "-" + code[2:]
            self.add(f"{summed}_{strong.index}", code or "0.0",
                     {f"{summed}_{b.index}" for b in others}, n,
                     f"{summed}_{strong.index} = {code}")

    def sort(self) -> list[Equation]:
        order: list[Equation] = []
        state: dict[str, int] = {}  # 0 unvisited, 1 visiting, 2 done
        stack_path: list[str] = []

        def visit(v: str) -> None:
            st = state.get(v, 0)
            if st == 2:
                return
            if st == 1:
                cyc = stack_path[stack_path.index(v):]
                elements = tuple(dict.fromkeys(self.eqs[x].element for x in cyc))
                raise AlgebraicLoopError(
                    "algebraic loop through " + " → ".join([*cyc, v])
                    + f" (elements {', '.join(elements)}); add a storage element (C or I) on "
                    "the loop or give one resistance the other causality", elements=elements)
            eq = self.eqs.get(v)
            if eq is None:
                raise ModelStructureError(f"variable {v} has no defining equation",
                                          elements=())
            state[v] = 1
            stack_path.append(v)
            for d in sorted(eq.deps):
                visit(d)
            stack_path.pop()
            state[v] = 2
            order.append(eq)

        for v in sorted(self.eqs, key=_var_key):
            visit(v)
        return order


def _var_key(v: str) -> tuple[int, str]:
    kind, _, idx = v.partition("_")
    return (int(idx) if idx.isdigit() else 0, kind)


def derive_equations(graph: BondGraph) -> EquationSystem:
    """Assign causality and derive the sorted causal equations of ``graph``."""
    return _Builder(graph).build()
