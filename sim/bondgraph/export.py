"""Export a bond graph as JSON or Graphviz DOT, with its causality, for checking by hand."""

from __future__ import annotations

import json
from typing import Any

from sim.bondgraph.causality import assign_causality
from sim.bondgraph.elements import LawCall
from sim.bondgraph.graph import BondGraph

__all__ = ["to_dict", "to_dot", "to_json"]


def _law(law: LawCall | None) -> str | None:
    return law.describe() if law is not None else None


def to_dict(graph: BondGraph) -> dict[str, Any]:
    """Elements, bonds (with the element that sets each effort), parameters, tables, outputs."""
    setter = assign_causality(graph)
    return {
        "name": graph.name,
        "elements": [
            {"name": e.name, "kind": str(e.kind), "law": _law(e.law),
             "flow_law": _law(e.flow_law), "effort_law": _law(e.effort_law),
             "description": e.description}
            for e in graph.elements.values()
        ],
        "bonds": [
            {"index": b.index, "from": b.src, "to": b.dst, "label": b.label,
             "effort_set_by": setter[b.index]}
            for b in graph.bonds
        ],
        "parameters": [
            {"name": p.name, "value": p.value, "unit": p.unit, "source": p.source}
            for p in graph.parameters.values()
        ],
        "tables": [
            {"name": t.name, "size": t.size, "unit": t.unit, "source": t.source}
            for t in graph.tables.values()
        ],
        "auxiliary_states": [
            {"name": a.name, "unit": a.unit,
             "derivative": a.signal if isinstance(a.signal, str) else a.signal.describe()}
            for a in graph.integrators.values()
        ],
        "outputs": [
            {"name": o.name, "unit": o.unit,
             "expr": o.expr.describe() if isinstance(o.expr, LawCall) else o.expr}
            for o in graph.outputs.values()
        ],
    }


def to_json(graph: BondGraph, indent: int = 2) -> str:
    """:func:`to_dict` as JSON text."""
    return json.dumps(to_dict(graph), indent=indent)


def to_dot(graph: BondGraph) -> str:
    """Graphviz DOT: half-arrows as arrowheads, the causal stroke as a ``tee`` mark.

    The stroke is drawn at the end of the bond that *receives* the effort (the end
    opposite the element that sets it), as in the usual bond-graph notation.
    """
    setter = assign_causality(graph)
    lines = [f'digraph "{graph.name}" {{', "  rankdir=LR;", "  node [shape=plaintext];"]
    for e in graph.elements.values():
        label = e.name if e.kind.value in ("0", "1") and e.name.startswith(e.kind.value) \
            else f"{e.kind}:{e.name}"
        lines.append(f'  "{e.name}" [label="{label}"];')
    for b in graph.bonds:
        stroke_at_dst = setter[b.index] == b.src
        tail = "none" if stroke_at_dst else "tee"
        head = "teehalfopen" if stroke_at_dst else "halfopen"
        lbl = f"{b.index}" + (f" {b.label}" if b.label else "")
        lines.append(f'  "{b.src}" -> "{b.dst}" [label="{lbl}", dir=both, '
                     f'arrowtail={tail}, arrowhead={head}];')
    lines.append("}")
    return "\n".join(lines) + "\n"
