"""Bond-graph engine: elements, graph, causality (SCAP), equations, compiled model, export."""

from sim.bondgraph.causality import assign_causality
from sim.bondgraph.elements import (
    GY,
    MGY,
    MTF,
    TF,
    C,
    Element,
    I,
    Kind,
    LawCall,
    MSe,
    MSf,
    One,
    R,
    Se,
    Sf,
    Zero,
    call,
)
from sim.bondgraph.equations import EquationSystem, derive_equations
from sim.bondgraph.export import to_dict, to_dot, to_json
from sim.bondgraph.graph import BondGraph
from sim.bondgraph.model import CompiledModel, IntegrationResult, compile_graph, fit_table

__all__ = [
    "GY",
    "MGY",
    "MTF",
    "TF",
    "BondGraph",
    "C",
    "CompiledModel",
    "Element",
    "EquationSystem",
    "I",
    "IntegrationResult",
    "Kind",
    "LawCall",
    "MSe",
    "MSf",
    "One",
    "R",
    "Se",
    "Sf",
    "Zero",
    "assign_causality",
    "call",
    "compile_graph",
    "derive_equations",
    "fit_table",
    "to_dict",
    "to_dot",
    "to_json",
]
