"""Cases of the accuracy study (:mod:`benchmarks.accuracy`): rigs, faults, readings.

Rigs: the paper-002 preset (through-rod cylinder) and a differential-cylinder rig (60 mm
bore, no rod on the cap side, one 30 mm rod: the rig of issue 11) that nothing in the
diagnosis was tuned on.  Readings come from the *transient* cycle (phase averages), not
from the steady fast path the diagnosis uses, with instrument noise drawn uniformly within
each instrument's class bound (flow ±1 %, pressure ±0.25 %, speed ±0.5 %, ratio ±1 %).

Fault draws (reported units of :mod:`diagnostics.hypotheses`):

* in the library: clearances × 1.2-2.0, pump leakage × 2-8, seat leak 1-6 × the pump's
  nominal leakage, relief setting 0.3 P0 up to 97 % of the healthy pump pressure (low
  enough to open at the case's load); pairs of the first three;
* beyond the prior ranges: clearances × 4.5-6, pump leakage × 30-60, seat leak 30-60,
  relief setting 0.15-0.25 × P0 — the truth lies outside every hypothesis;
* a mis-specified rig: the document's uncertain parameters (Lc, Ls, K, Fu, Kf, Rlp) are
  off by their stated uncertainty (ln θ/θ₀ = ±1 prior σ of
  :data:`diagnostics.commissioning.PRIOR_SD`, random signs) in the rig that made the
  readings, and the diagnosis uses the document.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from diagnostics.commissioning import PRIOR_SD
from diagnostics.quantity import DEFAULT_INSTRUMENTS
from sim.cycle import run_cycle
from sim.rigs import Condition, Rig, load_rig, reference_rig_document

__all__ = ["IN_LIBRARY", "Case", "differential_document", "draw_fault", "misspecified_rig",
           "noisy", "transient_readings"]

IN_LIBRARY = ("healthy", "cylinder", "valve", "pump", "relief_seat", "relief_setting",
              "cylinder+valve", "cylinder+pump", "valve+pump")
BEYOND = ("cylinder", "valve", "pump", "relief_seat", "relief_setting")


@dataclass
class Case:
    """One drawn case: which rig made the readings, what was wrong, at which condition."""

    suite: str
    rig: str
    truth: str
    in_library: bool
    overrides: dict[str, float]
    params: dict[str, float]
    load: float
    temperature: float
    extra: dict[str, Any] = field(default_factory=dict)


def differential_document() -> dict[str, Any]:
    """The preset document with a differential cylinder (60 mm bore, one 30 mm rod)."""
    doc: dict[str, Any] = copy.deepcopy(reference_rig_document())
    doc["name"] = "differential-60-30"
    doc["components"]["cylinder"]["parameters"]["rod1"]["value"] = 0.0
    return doc


def misspecified_rig(base: dict[str, Any], rng: np.random.Generator) -> tuple[Rig, dict[str, float]]:
    """The rig the readings come from when the document is off by its stated uncertainty:
    each uncertain parameter × exp(±PRIOR_SD) (signs drawn); returns the factors too."""
    doc = copy.deepcopy(base)
    doc["name"] = f"{base['name']}-as-built"
    factors = {}
    for key, sd in PRIOR_SD.items():
        role, name = key.split(".")
        f = float(np.exp(sd * rng.choice([-1.0, 1.0])))
        doc["components"][role]["parameters"][name]["value"] *= f
        factors[key] = f
    return load_rig(doc), factors


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def draw_fault(rig: Rig, truth: str, rng: np.random.Generator, *, beyond: bool,
               pump_pressure: float) -> tuple[dict[str, float], dict[str, float]]:
    """(graph overrides, true parameters in reported units) of ``truth`` on ``rig``."""
    ov: dict[str, float] = {}
    params: dict[str, float] = {}
    for comp in truth.split("+"):
        if comp in ("cylinder", "valve"):
            key, name = ("cylinder.cc", "cc") if comp == "cylinder" else ("valve.cv", "cv")
            f = _log_uniform(rng, 4.5, 6.0) if beyond else _log_uniform(rng, 1.2, 2.0)
            params[name] = ov[key] = rig.base[key] * f
        elif comp == "pump":
            k = _log_uniform(rng, 30.0, 60.0) if beyond else _log_uniform(rng, 2.0, 8.0)
            params["pump_leak"] = k
            ov["pump.Rlp"] = rig.base["pump.Rlp"] / k
        elif comp == "relief_seat":
            s = _log_uniform(rng, 30.0, 60.0) if beyond else _log_uniform(rng, 1.0, 6.0)
            params["seat_leak"] = s
            ov["relief.Gseat"] = s / rig.base["pump.Rlp"]
        elif comp == "relief_setting":
            p0 = rig.base["relief.Pset"]
            hi = min(0.97 * pump_pressure, p0)
            value = rng.uniform(0.15 * p0, 0.25 * p0) if beyond else \
                rng.uniform(0.3 * p0, max(hi, 0.3 * p0 * 1.01))
            params["Pset"] = ov["relief.Pset"] = float(value)
    return ov, params


def transient_readings(rig: Rig, ov: dict[str, float], load: float, temp: float
                       ) -> dict[str, float] | None:
    """Phase averages of the transient cycle; ``None`` if a phase does not complete."""
    res = run_cycle(rig, ov, Condition(load=load, oil_temperature=temp), timeseries=False)
    if not (res.working.completed and res.return_.completed):
        return None
    w, r = res.working, res.return_
    return {"pump_pressure": w["P_pump"], "p1": w["P1"], "p2": w["P2"],
            "flow_B": w["Q_meter_B"], "flow_C": w["Q_meter_C"],
            "pump_flow": w["Q_meter_B"] + w["Q_relief"], "speed_work": w["speed"],
            "speed_return": r["speed"], "velocity_ratio": res.velocity_ratio}


def noisy(values: dict[str, float], fields: tuple[str, ...], rng: np.random.Generator
          ) -> dict[str, float]:
    """``fields`` of ``values`` with noise uniform within each instrument's class bound."""
    out = {}
    for f in fields:
        inst = DEFAULT_INSTRUMENTS[f]
        half = inst.relative_bound * abs(values[f]) + inst.absolute_bound
        out[f] = values[f] + rng.uniform(-half, half)
    return out
