"""Cases of the accuracy study (:mod:`benchmarks.accuracy`): rigs, faults, readings.

Rigs: the paper-002 preset (through-rod cylinder) and a differential-cylinder rig (60 mm
bore, no rod on the cap side, one 30 mm rod: the rig of issue 11) that nothing in the
diagnosis was tuned on.  Readings come from the *transient* cycle, read as a measured
cycle is (:func:`diagnostics.cycle_readings.phase_reading`: phase averages over the middle
of the stroke, a linear encoder's speed), not from the steady fast path the diagnosis
uses, with instrument noise drawn uniformly within
each instrument's class bound (flow ±1 %, pressure ±0.25 %, speed ±0.5 %, ratio ±1 %).

Fault draws (reported units of :mod:`diagnostics.hypotheses`):

* in the library: **the diagnosis's own prior** — the truth with the frequencies of
  :data:`diagnostics.evidence.FLEET_PRIOR`, each of its parameters uniform in its fitting
  coordinate over its *worn* range (:meth:`diagnostics.hypotheses.FaultParameter.
  worn_bounds`: clearances 1.1-4 × nominal and leakage factors 1.33-20, log-uniform; seat
  leak 0.33-20 × the pump's nominal leakage conductance, log-uniform), a relief setting
  uniform over the part of its worn range (0.3-0.95 P0) that opens at the case's
  condition (below the healthy pump pressure: the prior of
  :func:`diagnostics.evidence.acting_relief_setting`).  The stated probabilities assume
  exactly this distribution, so the reliability table tests them and nothing else;
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
import pandas as pd

from diagnostics.commissioning import PRIOR_SD
from diagnostics.cycle_readings import phase_reading
from diagnostics.evidence import FLEET_PRIOR
from diagnostics.hypotheses import PARAMETERS
from diagnostics.measurement import PRESSURE_FIELDS
from diagnostics.quantity import DEFAULT_INSTRUMENTS
from diagnostics.signatures import evaluator
from sim.cycle import run_cycle
from sim.errors import SimulationError
from sim.rigs import Condition, Rig, load_rig, reference_rig_document

__all__ = ["AS_STATED", "INCIPIENT", "IN_LIBRARY", "Case", "Noise", "TransientReadings",
           "differential_document", "draw_fault", "draw_truth", "fault_size",
           "misspecified_rig", "noisy", "stated_condition", "transient_readings"]

IN_LIBRARY = ("healthy", "cylinder", "valve", "pump", "relief_seat", "relief_setting",
              "cylinder+valve", "cylinder+pump", "valve+pump")
BEYOND = ("cylinder", "valve", "pump", "relief_seat", "relief_setting")
#: leakage faults drawn between the document's value and the worn range
INCIPIENT = ("cylinder", "valve", "pump", "relief_seat")


@dataclass(frozen=True)
class Noise:
    """How an instrument's error is drawn, against the class bound ``a`` the record states
    (the diagnosis reads it as u = a/√3).

    Attributes
    ----------
    scale
        The errors' spread as a multiple of the stated one [-]: uniform within ±scale·a,
        or Gaussian of σ = scale·a/√3.
    shape
        ``"uniform"`` (the class read as stated) or ``"gauss"`` (the same σ at scale 1,
        with tails beyond the bound).
    mistake
        A mistake in the units the readings are stated in (:mod:`diagnostics.unit_mistakes`):
        ``"absolute_pressure"`` (every pressure reading an atmosphere high, the atmosphere
        drawn uniform in 95-103 kPa: weather and altitudes to about 550 m),
        ``"fahrenheit"`` (the oil temperature stated in °F), or ``""``.
    """

    scale: float = 1.0
    shape: str = "uniform"
    mistake: str = ""

    def draw(self, rng: np.random.Generator, half: float) -> float:
        """One error [unit of the reading] of an instrument of class bound ``half``."""
        if self.shape == "gauss":
            return float(rng.normal(0.0, self.scale * half / np.sqrt(3.0)))
        return float(rng.uniform(-self.scale * half, self.scale * half))


#: errors within the stated class (the diagnosis's own assumption)
AS_STATED = Noise()


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


def draw_truth(rng: np.random.Generator, truths: tuple[str, ...] = IN_LIBRARY) -> str:
    """A truth drawn with the frequencies of the fleet prior (renormalised over ``truths``)."""
    w = np.array([FLEET_PRIOR.get(t, 1.0) for t in truths])
    return str(truths[int(rng.choice(len(truths), p=w / w.sum()))])


def _prior_value(rig: Rig, name: str, rng: np.random.Generator) -> float:
    """A value of fault parameter ``name`` from its worn prior (uniform in ``z``)."""
    p = PARAMETERS[name]
    lo, hi = p.worn_bounds(rig)
    return p.from_z(float(rng.uniform(p.to_z(lo), p.to_z(hi))))


def draw_fault(rig: Rig, truth: str, rng: np.random.Generator, *, beyond: bool,
               pump_pressure: float, incipient: bool = False
               ) -> tuple[dict[str, float], dict[str, float]]:
    """(graph overrides, true parameters in reported units) of ``truth`` on ``rig``.

    In the library (``beyond=False``) from the diagnosis's prior (module docstring); a
    relief setting from the part of its worn range below ``pump_pressure`` [Pa] (the
    healthy pump pressure at the case's condition), where it opens.  Beyond the ranges
    (``beyond=True``): clearances × 4.5-6, leakage factors 30-60, a setting 0.15-0.25 P0.
    Incipient (``incipient=True``, leakage faults only): between the document's value and
    the start of the worn range — leakage × 1.1-1.33 (log-uniform), a seat leak 0.1-0.33.
    """
    if incipient:
        name = {"cylinder": "cc", "valve": "cv", "pump": "pump_leak",
                "relief_seat": "seat_leak"}[truth]
        leak = _log_uniform(rng, 1.1, 1.33) if name != "seat_leak" else \
            _log_uniform(rng, 0.1, 0.33)
        value = rig.base[PARAMETERS[name].graph_param] * leak ** (1 / 3) \
            if name in ("cc", "cv") else leak
        return ({PARAMETERS[name].graph_param: PARAMETERS[name].graph_value(rig, value)},
                {name: value})
    ov: dict[str, float] = {}
    params: dict[str, float] = {}
    for comp in truth.split("+"):
        if comp == "healthy":
            continue
        if comp in ("cylinder", "valve"):
            name = "cc" if comp == "cylinder" else "cv"
            value = rig.base[PARAMETERS[name].graph_param] * _log_uniform(rng, 4.5, 6.0) \
                if beyond else _prior_value(rig, name, rng)
        elif comp in ("pump", "relief_seat"):
            name = "pump_leak" if comp == "pump" else "seat_leak"
            value = _log_uniform(rng, 30.0, 60.0) if beyond else _prior_value(rig, name, rng)
        elif comp == "relief_setting":
            name = "Pset"
            p0 = rig.base["relief.Pset"]
            lo, hi = PARAMETERS["Pset"].worn_bounds(rig)
            value = float(rng.uniform(0.15 * p0, 0.25 * p0)) if beyond else \
                float(rng.uniform(lo, max(min(hi, pump_pressure), lo * 1.01)))
        else:
            raise ValueError(f"no fault {comp!r} in the library")
        params[name] = value
        ov[PARAMETERS[name].graph_param] = PARAMETERS[name].graph_value(rig, value)
    return ov, params


@dataclass
class TransientReadings:
    """Phase averages of one transient cycle, as a rig's instruments would read them.

    Attributes
    ----------
    values
        Readings [SI] (keys of :data:`diagnostics.observations.OBSERVABLE_UNITS`); a speed
        of a stroke that did not complete is the creep speed the encoder saw (travel over
        the phase's time limit), and a reading that does not exist (the velocity ratio of
        a return stroke that did not move) is absent.
    stalled
        Phases that did not reach their end of stroke (``"working"``, ``"return"``).
    """

    values: dict[str, float]
    stalled: tuple[str, ...]


def _read(ts: pd.DataFrame, phase: str, completed: bool, stroke: float) -> dict[str, float]:
    """A phase of the simulated cycle as a rig's meters read it
    (:func:`diagnostics.cycle_readings.phase_reading`, the function a measured cycle goes
    through): a completed stroke over the middle 80 % of its travel, its speed a linear
    encoder's (the position's slope there: the steady speed; the simulator's
    stroke/duration counts the start-up and reads 0.1 % low, 0.4 σ of the encoder); a
    stalled or creeping one over the last half of the phase (the start-up transient, in
    which the hoses fill and a flow may reverse, left out), and the creep speed there."""
    rows = ts[ts["phase"] == phase]
    channels = {c.split(" [")[0]: rows[c].to_numpy() for c in rows.columns if " [" in c}
    # the simulated position is exact: every creep is read (a measured one's resolution is
    # the reader's HELD_SHARE of the stroke), and the class noise is added to it later
    read = phase_reading(phase, channels.pop("t"), channels["x"], channels, stroke,
                         completed=completed, held_share=0.0)
    return {**read.averages, "speed": read.speed}


def transient_readings(rig: Rig, ov: dict[str, float], load: float, temp: float
                       ) -> TransientReadings:
    """Phase averages of the transient cycle, stalled or creeping strokes included.

    A stroke that does not reach its end within the phase's time limit (the piston stalls
    or creeps: a clearance beyond the prior range, a relief setting near the load
    pressure, a hot differential cylinder on its return) is read as a rig reads it: its
    pressures, flows and speed are those of the settled stall or creep state (the last
    half of the phase, :func:`_read`); a moving stroke's speed is a linear encoder's over the
    middle of its travel; a return stroke after a stalled working stroke
    is not a stroke (it starts where the piston stalled) and gives no speed; the velocity
    ratio is given only when both strokes moved and the working one completed.
    """
    res = run_cycle(rig, ov, Condition(load=load, oil_temperature=temp),
                    timeseries=True)
    assert res.timeseries is not None
    stroke = rig.base["cylinder.stroke"]
    w = _read(res.timeseries, "working", res.working.completed, stroke)
    r = _read(res.timeseries, "return", res.return_.completed, stroke)
    values = {"pump_pressure": w["P_pump"], "p1": w["P1"], "p2": w["P2"],
              "flow_B": w["Q_meter_B"], "flow_C": w["Q_meter_C"],
              "pump_flow": w["Q_meter_B"] + w["Q_relief"], "speed_work": w["speed"],
              "speed_return": r["speed"]}
    if not res.working.completed:
        del values["speed_return"]
    elif values["speed_work"] > 0.0 and values["speed_return"] > 0.0:
        values["velocity_ratio"] = values["speed_work"] / values["speed_return"]
    values = {k: float(v) for k, v in values.items() if np.isfinite(v)}
    stalled = tuple(ph.phase for ph in (res.working, res.return_) if not ph.completed)
    return TransientReadings(values, stalled)


def noisy(values: dict[str, float], fields: tuple[str, ...], rng: np.random.Generator,
          noise: Noise = AS_STATED) -> dict[str, float]:
    """``fields`` of ``values`` with noise uniform within each instrument's class bound,
    or as ``noise`` draws it (a field the readings lack, a speed of a stroke that did not
    move, is left out)."""
    out = {}
    for f in fields:
        if f not in values or (f.startswith("speed") and values[f] <= 0.0):
            continue
        inst = DEFAULT_INSTRUMENTS[f]
        half = inst.relative_bound * abs(values[f]) + inst.absolute_bound
        out[f] = values[f] + noise.draw(rng, half)
    if noise.mistake == "absolute_pressure":
        atmosphere = float(rng.uniform(95e3, 103e3))
        out |= {f: v + atmosphere for f, v in out.items() if f in PRESSURE_FIELDS}
    return out


def stated_condition(load: float, temp: float, rng: np.random.Generator,
                     noise: Noise = AS_STATED) -> tuple[float, float]:
    """(load [N], oil temperature [°C]) as a record states them: the true values with the
    error of the default load cell (±1 %) and thermometer (±1 °C), uniform within the class
    bound, the σ the diagnosis assumes for a stated condition
    (:data:`diagnostics.quantity.DEFAULT_INSTRUMENTS`), or as ``noise`` draws it."""
    ui = DEFAULT_INSTRUMENTS["condition.load_force"]
    ti = DEFAULT_INSTRUMENTS["condition.oil_temperature"]
    half_l = ui.relative_bound * abs(load) + ui.absolute_bound
    half_t = ti.relative_bound * abs(temp) + ti.absolute_bound
    stated = load + noise.draw(rng, half_l), temp + noise.draw(rng, half_t)
    if noise.mistake == "fahrenheit":
        return stated[0], 32.0 + 1.8 * stated[1]
    return stated


def fault_size(rig: Rig, ov: dict[str, float], load: float, temp: float,
               fields: tuple[str, ...]) -> float:
    """The fault's largest reading shift [σ]: max over ``fields`` of |faulty − healthy| / u,
    both from the steady model of ``rig`` at the true condition, u the standard
    uncertainty of the field's default instrument (class bound / √3) at the larger of the
    two readings (a speed that drops to 0 on the end stop keeps its healthy σ).  A reading
    that the fault takes away (a velocity ratio with the return stroke on its end stop)
    counts as an infinite shift; NaN where either state has no steady solution."""
    ev = evaluator(rig, Condition(load=load, oil_temperature=temp))
    try:
        healthy = ev.nominal()
        faulty = ev(np.array([ov.get(k, rig.base[k]) for k in ev.names]))
    except SimulationError:
        return float("nan")
    worst = 0.0
    for f in fields:
        h, y = healthy.get(f, np.nan), faulty.get(f, np.nan)
        if not np.isfinite(h):
            continue
        if not np.isfinite(y):
            return float("inf")
        inst = DEFAULT_INSTRUMENTS[f]
        u = (inst.relative_bound * max(abs(y), abs(h)) + inst.absolute_bound) / np.sqrt(3.0)
        if u > 0.0:
            worst = max(worst, abs(y - h) / u)
    return float(worst)
