"""The ``pump-valve-cylinder`` circuit of paper 002 (its Figure 1).

A pump with a relief valve feeds a 4/2 valve through a supply line; hoses join ports A and
B to a double-acting cylinder, with a check valve in the A line (eqs. 53-54); throttle
valves H (across the piston) and I (valve P→T) stand for worn clearances (§2.7).  Meters B
(flow into the valve's P port) and C (flow out of chamber 2) are the paper's flowmeters;
``P_valve_B``, the pressure at port B, is an extra sensor a user may log (with P2 and
meter C it gives hose B's effort balance).

The hoses A and B are the project's addition, in the manner of paper 000 §4's hose
sections: paper 002's equations (1-54) have no line element between valve and cylinder but
the supply line's drop PRpv.  Their laminar resistance 128·μ·L/(π·d⁴) (3.1e7 Pa·s/m³ at
40 °C, 0.14 bar at the pump's flow) is exact at 40 °C (Re ≈ 1,000) and reads low above
≈ 60 °C, where the flow turns transitional (Re ≈ 2,300 at 60 °C, 4,200 at 80 °C); the
calibrated seal and land lengths absorb it at 40 °C.
"""

from __future__ import annotations

from sim.bondgraph import BondGraph, LawCall
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
from sim.params import Param
from sim.rigs.circuits import Circuit, register

__all__ = ["CIRCUIT", "build_graph"]


def build_graph(name: str = "pump-valve-cylinder") -> tuple[BondGraph, list[Derivation]]:
    """The bond graph of the circuit (module docstring), with default parameters."""
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
    g.output("P_valve_B", f"effort:{valve.ports['B']}", "Pa",
             "pressure at valve port B (hose B's valve end; not on paper 002's logger)")
    g.output("Q_throttle_H", "flow:throttle_H.path", "m^3/s", "bypass through throttle H")
    g.output("Q_throttle_I", "flow:throttle_I.path", "m^3/s", "bypass through throttle I")
    return g, [f.derive for f in frags if f.derive is not None]


CIRCUIT = register(Circuit(
    name="pump-valve-cylinder",
    cycle=True,
    title="paper 002 Figure 1: pump, relief valve, 4/2 valve, hoses, double-acting cylinder",
    roles={
        "pump": "fixed_displacement_pump",
        "relief": "relief_valve",
        "supply_line": "fixed_drop_line",
        "valve": "directional_valve_4_2",
        "hose_A": "hose",
        "hose_B": "hose",
        "check": "check_valve",
        "cylinder": "double_acting_cylinder",
        "throttle_H": "throttle_valve",
        "throttle_I": "throttle_valve",
    },
    build=build_graph,
    condition=(
        *load.PARAMETERS,
        Param("oil_temperature", "degC", 40.0, "ISO VG 46 reference temperature",
              "oil temperature", lower=-30.0, upper=150.0, lower_inclusive=True),
    ),
    condition_targets={"load": "load.force", "back_pressure": "load.back_pressure"},
))
