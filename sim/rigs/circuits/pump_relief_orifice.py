"""The ``pump-relief-orifice`` circuit: the ZeMA rig's working circuit at the level its data support.

Helwig, Pignanelli, Schütze, I2MTC-2015 (doi:10.1109/I2MTC.2015.7151267), Fig. 1: a motor
pump (fixed displacement) with a relief valve feeds the working circuit, whose flow (FS1)
and pump pressure (PS1) are measured; the valves and accumulator behind FS1 are not
published in enough detail to model, so the working circuit is one orifice to tank whose
opening sets the plateau pressure.  The pump's internal leakage is paper 002 eq. 5's linear
leakage ``Qlp = Pp/Rlp``; the relief valve is paper 002 eq. 6.
"""

from __future__ import annotations

from sim.bondgraph import BondGraph, Se, Zero
from sim.bondgraph.laws import constant
from sim.components import pump, relief_valve, throttle
from sim.components.base import Derivation
from sim.params import Param
from sim.rigs.circuits import Circuit, register

__all__ = ["CIRCUIT", "build_graph"]


def build_graph(name: str = "pump-relief-orifice") -> tuple[BondGraph, list[Derivation]]:
    """The bond graph of the circuit (module docstring), with default parameters."""
    g = BondGraph(name)
    for k, v in (("mu", 0.04), ("rho", 870.0), ("beta", 1.5e9)):
        g.parameter(f"fluid.{k}", v, {"mu": "Pa*s", "rho": "kg/m^3", "beta": "Pa"}[k],
                    "derived from the fluid and the oil temperature")
    g.parameter("tank.pressure", 0.0, "Pa", "tank at atmospheric pressure (gauge 0)")
    frag = pump.build(g, "pump")
    relief_valve.build(g, "relief", "pump.out")
    g.add(Zero("tank.node", description="tank"))
    g.add(Se("tank", constant, "p:tank.pressure", description="tank pressure"))
    g.connect("tank", "tank.node")
    throttle.build(g, "work", "pump.out", "tank.node")
    g.output("Q_work", "flow:work.path", "m^3/s", "working-circuit flow (ZeMA FS1)")
    return g, [f.derive for f in (frag,) if f.derive is not None]


CIRCUIT = register(Circuit(
    name="pump-relief-orifice",
    title="ZeMA rig (Helwig 2015 Fig. 1) at the data's level: pump, relief valve, working "
          "orifice to tank",
    roles={"pump": "fixed_displacement_pump", "relief": "relief_valve", "work": "throttle_valve"},
    build=build_graph,
    condition=(
        Param("oil_temperature", "degC", 45.0, "ZeMA data: TS1 mean of all 2205 cycles "
              "(36-56 °C by cooler state)", "oil temperature", lower=-30.0, upper=150.0,
              lower_inclusive=True),
    ),
    condition_targets={},
))
