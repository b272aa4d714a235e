"""Synthetic measurement records from the rig model (tests only)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.quantity import DEFAULT_INSTRUMENTS
from sim.cycle import run_cycle
from sim.rigs import Condition, Rig
from sim.steady import steady_cycle

FULL = ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "speed_work", "speed_return")
NO_FLOW = ("pump_pressure", "p1", "p2", "speed_work", "speed_return")
RATIO = ("velocity_ratio",)


def readings(rig: Rig, overrides: Mapping[str, float], load: float, temperature: float,
             *, transient: bool = False) -> dict[str, float]:
    """Noise-free readings of every field (steady path, or the transient's phase averages)."""
    cond = Condition(load=load, oil_temperature=temperature)
    s = run_cycle(rig, overrides, cond, timeseries=False) if transient else \
        steady_cycle(rig, overrides, cond)
    w, r = s.working, s.return_
    return {"pump_pressure": w["P_pump"], "p1": w["P1"], "p2": w["P2"],
            "flow_B": w["Q_meter_B"], "flow_C": w["Q_meter_C"],
            "pump_flow": w["Q_meter_B"] + w["Q_relief"], "speed_work": w["speed"],
            "speed_return": r["speed"], "velocity_ratio": s.velocity_ratio}


def record(rig: Rig, overrides: Mapping[str, float], *, load: float = 2100.0,
           temperature: float = 40.0, fields: Sequence[str] = FULL,
           rng: np.random.Generator | None = None, transient: bool = False,
           values: Mapping[str, float] | None = None) -> MeasurementRecord:
    """A record with ``fields``; with ``rng``, readings carry their instruments' noise
    (uniform within the class bound, as the classes are read)."""
    vals = dict(values) if values is not None else readings(rig, overrides, load, temperature,
                                                            transient=transient)
    out = {}
    for f in fields:
        v = vals[f]
        if rng is not None:
            inst = DEFAULT_INSTRUMENTS[f]
            half = inst.relative_bound * abs(v) + inst.absolute_bound
            v = v + rng.uniform(-half, half)
        out[f] = v
    cond = OperatingCondition.from_readings({"oil_temperature": temperature, "load_force": load})
    return MeasurementRecord.from_readings("rig-1", cond, out)
