"""Sequential causality assignment procedure (SCAP).

For every bond we decide which end imposes the effort (the other end then imposes the
flow; the causal stroke sits at the end that *receives* the effort).  The order is the
classical one (Karnopp, Margolis & Rosenberg, *System Dynamics*, ch. 5):

1. sources take their required causality, and it is propagated through junctions and
   two-ports;
2. each storage element takes integral causality (C imposes effort, I imposes flow),
   with propagation after each;
3. each resistance still free takes the causality for which it has a law (flow-out
   preferred), with propagation;
4. bonds still free (zero-order causal paths between junctions) are set arbitrarily.

Conflicts are errors naming the elements.  A storage element left in derivative
causality is refused (:class:`~sim.errors.DerivativeCausalityError`); algebraic loops are
found later, when the equations are sorted.
"""

from __future__ import annotations

from sim.bondgraph.elements import STORAGES, TWO_PORTS_GY, TWO_PORTS_TF, Kind
from sim.bondgraph.graph import BondGraph
from sim.errors import CausalityError, DerivativeCausalityError

__all__ = ["assign_causality"]


class _Assigner:
    def __init__(self, graph: BondGraph) -> None:
        self.g = graph
        self.setter: list[str | None] = [None] * len(graph.bonds)
        self.multiports = [e.name for e in graph.elements.values()
                           if e.kind in (Kind.ZERO, Kind.ONE, *TWO_PORTS_TF, *TWO_PORTS_GY)]

    def set(self, bond: int, setter: str, why: str) -> None:
        cur = self.setter[bond]
        b = self.g.bonds[bond]
        if cur is None:
            self.setter[bond] = setter
        elif cur != setter:
            raise CausalityError(
                f"causality conflict on bond {b.src}→{b.dst}: {why} wants {setter!r} to set the "
                f"effort, but {cur!r} already does", elements=(b.src, b.dst))

    def propagate(self) -> None:
        changed = True
        while changed:
            changed = False
            for name in self.multiports:
                if self._propagate_one(name):
                    changed = True

    def _propagate_one(self, name: str) -> bool:
        el = self.g.elements[name]
        bonds = self.g.bonds_of(name)
        before = list(self.setter)
        if el.kind in (Kind.ZERO, Kind.ONE):
            # 0: exactly one bond brings effort in (setter != J);
            # 1: exactly one bond gets its effort from J (setter == J).
            special = [b for b in bonds if self._is_special(el.kind, name, b.index)]
            free = [b for b in bonds if self.setter[b.index] is None]
            if len(special) > 1:
                what = "effort-setting bonds" if el.kind is Kind.ZERO else "flow-setting bonds"
                raise CausalityError(
                    f"{el.kind}-junction {name!r} has {len(special)} {what} "
                    f"({', '.join(b.other(name) for b in special)}); it allows one",
                    elements=(name, *(b.other(name) for b in special)))
            if len(special) == 1:
                for b in free:
                    self._set_ordinary(el.kind, name, b.index)
            elif len(free) == 1:
                self._set_special(el.kind, name, free[0].index)
            elif not free and not special:
                raise CausalityError(
                    f"{el.kind}-junction {name!r} has no bond that determines its "
                    f"{'effort' if el.kind is Kind.ZERO else 'flow'}",
                    elements=(name, *(b.other(name) for b in bonds)))
        elif el.kind in TWO_PORTS_TF:
            b1, b2 = bonds
            s1, s2 = self.setter[b1.index], self.setter[b2.index]
            if s1 is not None and s2 is None:
                self.set(b2.index, b2.other(name) if s1 == name else name, f"TF {name!r}")
            elif s2 is not None and s1 is None:
                self.set(b1.index, b1.other(name) if s2 == name else name, f"TF {name!r}")
            elif s1 is not None and s2 is not None and (s1 == name) == (s2 == name):
                raise CausalityError(f"transformer {name!r} must pass effort through",
                                     elements=(name, b1.other(name), b2.other(name)))
        elif el.kind in TWO_PORTS_GY:
            b1, b2 = bonds
            s1, s2 = self.setter[b1.index], self.setter[b2.index]
            if s1 is not None and s2 is None:
                self.set(b2.index, name if s1 == name else b2.other(name), f"GY {name!r}")
            elif s2 is not None and s1 is None:
                self.set(b1.index, name if s2 == name else b1.other(name), f"GY {name!r}")
            elif s1 is not None and s2 is not None and (s1 == name) != (s2 == name):
                raise CausalityError(f"gyrator {name!r} must set both efforts or neither",
                                     elements=(name, b1.other(name), b2.other(name)))
        return before != self.setter

    def _is_special(self, kind: Kind, name: str, bond: int) -> bool:
        s = self.setter[bond]
        if s is None:
            return False
        return (s != name) if kind is Kind.ZERO else (s == name)

    def _set_ordinary(self, kind: Kind, name: str, bond: int) -> None:
        b = self.g.bonds[bond]
        self.set(bond, name if kind is Kind.ZERO else b.other(name), f"junction {name!r}")

    def _set_special(self, kind: Kind, name: str, bond: int) -> None:
        b = self.g.bonds[bond]
        self.set(bond, b.other(name) if kind is Kind.ZERO else name, f"junction {name!r}")

    def run(self) -> list[str]:
        g = self.g
        for el in g.by_kind(Kind.SE, Kind.MSE, Kind.SF, Kind.MSF):
            (b,) = g.bonds_of(el.name)
            effort_out = el.kind in (Kind.SE, Kind.MSE)
            self.set(b.index, el.name if effort_out else b.other(el.name), f"source {el.name!r}")
            self.propagate()
        for el in g.by_kind(*STORAGES):
            (b,) = g.bonds_of(el.name)
            want = el.name if el.kind is Kind.C else b.other(el.name)
            if self.setter[b.index] is None:
                self.set(b.index, want, f"storage {el.name!r}")
                self.propagate()
        bad = []
        for el in g.by_kind(*STORAGES):
            (b,) = g.bonds_of(el.name)
            want = el.name if el.kind is Kind.C else b.other(el.name)
            if self.setter[b.index] != want:
                bad.append(el.name)
        if bad:
            raise DerivativeCausalityError(
                "storage element(s) in derivative causality: " + ", ".join(bad)
                + " (their state is fixed by other storages or sources; merge them or add "
                "a resistance between them)", elements=tuple(bad))
        for el in g.by_kind(Kind.R):
            (b,) = g.bonds_of(el.name)
            if self.setter[b.index] is None:
                flow_out = el.flow_law is not None
                self.set(b.index, b.other(el.name) if flow_out else el.name, f"R {el.name!r}")
                self.propagate()
        for b in g.bonds:
            if self.setter[b.index] is None:
                self.set(b.index, b.src, "arbitrary choice")
                self.propagate()
        for el in g.by_kind(Kind.R):
            (b,) = g.bonds_of(el.name)
            if self.setter[b.index] == el.name and el.effort_law is None:
                raise CausalityError(
                    f"R {el.name!r} must give its effort from its flow, but it has only a "
                    "flow law (add an effort law or a storage element next to it)",
                    elements=(el.name,))
            if self.setter[b.index] != el.name and el.flow_law is None:
                raise CausalityError(
                    f"R {el.name!r} must give its flow from its effort, but it has only an "
                    "effort law (add a flow law or a storage element next to it)",
                    elements=(el.name,))
        return [s if s is not None else "" for s in self.setter]


def assign_causality(graph: BondGraph) -> list[str]:
    """Assign causality to every bond of ``graph``.

    Returns
    -------
    list of str
        For each bond (by index) the name of the element that imposes its effort.

    Raises
    ------
    CausalityError, DerivativeCausalityError
        With the names of the elements involved.
    """
    graph.check()
    return _Assigner(graph).run()
