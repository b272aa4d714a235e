"""Random diagnosis records for the fast-path benchmark and its equivalence test.

A record: a fault of the library (healthy, a single or a pair) at a random severity across
its worn prior range, a random oil temperature (20-60 °C) and load (5-60 % of the stall
load), readings from the rig's steady model with instrument noise (uniform within each
instrument's class bound), on a given sensor subset.  :func:`stalled_record` draws until
the working piston sits on its end stop (loads 30-100 % of the stall load; the speeds and
the velocity ratio of a stroke that does not move are not read, as on a rig).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from diagnostics.hypotheses import HYPOTHESES, PARAMETERS
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.quantity import DEFAULT_INSTRUMENTS
from diagnostics.signatures import GRAPH_PARAMETERS, evaluator
from sim.errors import InputError, SimulationError
from sim.rigs import Condition, Rig

__all__ = ["FULL", "SUBSETS", "random_record", "random_records", "stalled_record"]

FULL = ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "speed_work", "speed_return")
SUBSETS: tuple[tuple[str, ...], ...] = (
    FULL, ("pump_pressure", "p1", "p2", "speed_work", "speed_return"), ("velocity_ratio",),
    ("pump_pressure", "p1", "p2", "speed_work"),
    ("flow_B", "flow_C", "speed_work", "speed_return"), ("p1", "p2", "velocity_ratio"))


def random_record(rng: np.random.Generator, rig: Rig,
                  subsets: Sequence[tuple[str, ...]] = SUBSETS, *,
                  loads: tuple[float, float] = (0.05, 0.6), held: bool = False
                  ) -> MeasurementRecord | None:
    """A noisy record of a random fault at a random condition (None: the truth has no
    operating point, or a reading no record can carry).  ``loads``: the load's range as
    shares of the stall load ``Pset·A1`` [-]; ``held``: only a working piston on its end
    stop (else None), whose zero speeds and velocity ratio are left out."""
    hyp = HYPOTHESES[int(rng.integers(len(HYPOTHESES)))]
    faults = {}
    for name in hyp.parameters:
        p = PARAMETERS[name]
        lo, hi = p.worn_bounds(rig)
        z = rng.uniform(p.to_z(lo), p.to_z(hi))
        faults[p.graph_param] = p.graph_value(rig, p.from_z(z))
    temperature = float(rng.uniform(20.0, 60.0))
    load = (float(rng.uniform(*loads)) * rig.base["relief.Pset"]
            * rig.values()["cylinder.A1"])
    cond = Condition(load=load, oil_temperature=temperature)
    try:
        vals = evaluator(rig, cond)(np.array([faults.get(n, rig.base[n])
                                              for n in GRAPH_PARAMETERS]))
    except SimulationError:
        return None
    if held and vals["speed_work"] != 0.0:
        return None
    fields = subsets[int(rng.integers(len(subsets)))]
    out = {}
    for f in fields:
        v = vals[f]
        if held and (f == "velocity_ratio" or (f.startswith("speed") and v == 0.0)):
            continue
        if not math.isfinite(v):
            return None
        inst = DEFAULT_INSTRUMENTS[f]
        half = inst.relative_bound * abs(v) + inst.absolute_bound
        out[f] = v + float(rng.uniform(-half, half))
    if not out:
        return None
    oc = OperatingCondition.from_readings({"oil_temperature": temperature, "load_force": load})
    try:
        return MeasurementRecord.from_readings("r", oc, out)
    except InputError:
        return None


def stalled_record(rng: np.random.Generator, rig: Rig,
                   subsets: Sequence[tuple[str, ...]] = SUBSETS) -> MeasurementRecord:
    """A noisy record of :func:`random_record` whose working piston sits on its end stop
    (loads 30-100 % of the stall load; drawn until one is)."""
    while True:
        rec = random_record(rng, rig, subsets, loads=(0.3, 1.0), held=True)
        if rec is not None:
            return rec


def random_records(rng: np.random.Generator, rig: Rig, n: int,
                   subsets: Sequence[tuple[str, ...]] = SUBSETS) -> list[MeasurementRecord]:
    """``n`` records of :func:`random_record` (each at its own condition)."""
    out: list[MeasurementRecord] = []
    while len(out) < n:
        rec = random_record(rng, rig, subsets)
        if rec is not None:
            out.append(rec)
    return out
