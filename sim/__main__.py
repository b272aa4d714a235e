"""``python -m sim``: run a demo cycle of the reference rig, or print/export its bond graph.

Examples
--------
``python -m sim demo --fault worn_spool --load 4200``
``python -m sim graph --format dot > rig.dot``
"""

from __future__ import annotations

import argparse
import sys

from sim.bondgraph import derive_equations, to_dot, to_json
from sim.cycle import run_cycle
from sim.errors import HydrodiagError
from sim.rigs import Condition, load_rig, reference_rig
from sim.scenarios import FAULTS, fault_overrides


def _demo(args: argparse.Namespace) -> int:
    rig = load_rig(args.rig) if args.rig else reference_rig()
    own = rig.default_condition()   # the rig file's condition where an option is left out
    cond = Condition(load=own.load if args.load is None else args.load,
                     back_pressure=own.back_pressure,
                     oil_temperature=(own.oil_temperature if args.temperature is None
                                      else args.temperature))
    res = run_cycle(rig, fault_overrides(rig, args.fault), cond, timeseries=False)
    print(f"rig {rig.spec.name}, fault {args.fault}, load {cond.load:g} N, "
          f"oil {cond.oil_temperature:g} °C")
    for key, value in res.summary().items():
        print(f"  {key:36s} {value: .6g}")
    return 0


def _graph(args: argparse.Namespace) -> int:
    from sim.rigs.assembly import build_graph_with_effects

    rig = load_rig(args.rig) if args.rig else reference_rig()
    # a rig of its own: its circuit and its effects' elements (a modelling engineer's pass)
    g, _ = build_graph_with_effects(rig.circuit, rig.spec.effect_types)
    if args.format == "dot":
        print(to_dot(g), end="")
    elif args.format == "json":
        print(to_json(g))
    else:
        print(derive_equations(g).describe())
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the process exit code (2 for invalid input)."""
    ap = argparse.ArgumentParser(prog="python -m sim", description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("demo", help="simulate one working + return cycle and print its summary")
    d.add_argument("--rig", help="rig file (YAML/JSON); default: the paper-002 reference rig")
    d.add_argument("--fault", choices=FAULTS, default="healthy")
    d.add_argument("--load", type=float, default=None,
                   help="load force [N]; default: the rig file's (2100 N for the reference)")
    d.add_argument("--temperature", type=float, default=None,
                   help="oil temperature [°C]; default: the rig file's (40 °C for the reference)")
    gr = sub.add_parser("graph", help="print the rig's bond graph")
    gr.add_argument("--format", choices=("equations", "json", "dot"), default="equations")
    gr.add_argument("--rig", help="rig file (YAML/JSON): its circuit and effects; default: "
                    "the paper-002 reference rig")
    args = ap.parse_args(argv)
    try:
        return _demo(args) if args.cmd == "demo" else _graph(args)
    except HydrodiagError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
