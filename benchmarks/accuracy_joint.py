"""The accuracy study's joint-visit suite (:mod:`benchmarks.accuracy`, suite ``joint``).

A visit is what an engineer records at a rig: one oil temperature, three loads (2.1, 4.2
and 6.3 kN), three records diagnosed together (``"joint": true``).  Each record's readings
come from the transient model with noise uniform within each instrument's class, and each
states its load and oil temperature with its load cell's and thermometer's error (drawn
per record: :func:`benchmarks.accuracy_cases.stated_condition`).  The fault is a single
leakage fault of seal, spool or pump drawn from its worn prior
(:func:`benchmarks.accuracy_cases.draw_fault`), on the preset and the differential rig in
turn, oil 25-60 °C.  Figures per sensor set (full, no flow meters): the share not
explained (a single fault of the library: the right answer is a name), the share whose top
answer is the truth and the top answer's stated probability on average (above that share
where the probabilities are over-confident), and — what the history keeps — the share
with an estimate of the truth's component stored, the share of those whose 95 % interval
holds the truth (:func:`benchmarks.accuracy.stored_estimate`) and their median width.
The suite exists because a visit's three independent temperature statements once made
worn seals "not explained" (5 of 30 without flow meters) where single records were not.

With ``shared=True`` the visit's records share their instruments' errors: each instrument
(every reading's, the load cell, the thermometer) is off by one gain within its class
bound, drawn once per visit (:class:`VisitInstruments`: a calibration error, what a class
bound mostly is), and the sensor sets read the same instruments.  Each visit is diagnosed
twice on the same readings: as independent records (what the diagnosis assumes unless told:
what that assumption costs) and with each record stating ``calibration_share`` 1 (its
stated uncertainties are its instruments' calibration errors,
:mod:`diagnostics.shared_errors`), figures under ``"stated"``
(:mod:`benchmarks.accuracy_noise`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from benchmarks.accuracy_cases import (
    Case,
    differential_document,
    draw_fault,
    misspecified_rig,
    noisy,
    stated_condition,
    transient_readings,
)
from diagnostics.commissioning import commission
from diagnostics.diagnose import Diagnosis, diagnose
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.quantity import DEFAULT_INSTRUMENTS
from sim.rigs import Rig, load_rig, reference_rig, reference_rig_document

__all__ = ["JOINT_LOADS", "JOINT_SETS", "VisitInstruments", "joint_suite",
           "shared_commissioning"]

#: the loads of a visit [N]
JOINT_LOADS = (2100.0, 4200.0, 6300.0)

#: sensor sets of the suite
JOINT_SETS = {"full": ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "speed_work",
                       "speed_return"),
              "no_flow_meters": ("pump_pressure", "p1", "p2", "speed_work", "speed_return")}

StoredFn = Callable[[Case, Diagnosis, Rig, float], "dict[str, Any] | None"]


class VisitInstruments:
    """One visit's instruments, each off by a gain within its class bound drawn once (its
    first use) and kept for every record and sensor set of the visit."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng
        self.gain: dict[str, float] = {}

    def _error(self, key: str, value: float) -> float:
        if key not in self.gain:
            self.gain[key] = float(self.rng.uniform(-1.0, 1.0))
        inst = DEFAULT_INSTRUMENTS[key]
        return self.gain[key] * (inst.relative_bound * abs(value) + inst.absolute_bound)

    def read(self, values: dict[str, float], fields: tuple[str, ...]) -> dict[str, float]:
        """``fields`` of ``values`` as these instruments read them (the fields
        :func:`benchmarks.accuracy_cases.noisy` leaves out, left out)."""
        return {f: values[f] + self._error(f, values[f]) for f in fields
                if f in values and not (f.startswith("speed") and values[f] <= 0.0)}

    def stated(self, load: float, temp: float) -> tuple[float, float]:
        """(load [N], oil temperature [°C]) as this load cell and thermometer state them."""
        return (load + self._error("condition.load_force", load),
                temp + self._error("condition.oil_temperature", temp))


def joint_suite(n: int, rng: np.random.Generator, stored: StoredFn, *,
                shared: bool = False, tell: bool | None = None) -> dict[str, Any]:
    """``n`` visits (module docstring); ``stored`` scores the history's estimate of a
    case (:func:`benchmarks.accuracy.stored_estimate`); ``shared``: the records share
    their instruments' errors; ``tell`` (default: ``shared``): diagnose each visit again
    with its records stating ``calibration_share`` 1.  Prints one line per sensor set."""
    tell = shared if tell is None else tell
    rigs = {"preset": reference_rig(), "differential": load_rig(differential_document())}
    rows: dict[str, list[dict[str, float]]] = {s: [] for s in JOINT_SETS}
    told: dict[str, list[dict[str, float]]] = {s: [] for s in JOINT_SETS}
    for k in range(n):
        rname = ("preset", "differential")[k % 2]
        rig = rigs[rname]
        truth = ("cylinder", "valve", "pump")[int(rng.integers(3))]
        temp = float(rng.uniform(25.0, 60.0))
        ov, params = draw_fault(rig, truth, rng, beyond=False, pump_pressure=np.inf)
        case = Case("joint", rname, truth, True, ov, params, JOINT_LOADS[0], temp)
        readings = [transient_readings(rig, ov, load, temp).values for load in JOINT_LOADS]
        visit = VisitInstruments(rng) if shared else None
        stated = [stated_condition(load, temp, rng) if visit is None else
                  visit.stated(load, temp) for load in JOINT_LOADS]
        for sname, fields in JOINT_SETS.items():
            records = []
            for values, (sl, st) in zip(readings, stated, strict=True):
                cond = OperatingCondition.from_readings({"oil_temperature": st,
                                                         "load_force": sl})
                read = noisy(values, fields, rng) if visit is None else \
                    visit.read(values, fields)
                records.append(MeasurementRecord.from_readings("visit", cond, read))
            shares = [records, [replace(r, calibration_share=1.0) for r in records]] \
                if tell else [records]
            for into, recs in zip((rows, told), shares, strict=False):
                d = diagnose(rig, recs)
                st = stored(case, d, rig, stated[0][1]) or {"stored": 0.0,
                                                            "held": float("nan")}
                into[sname].append({"explained": float(d.explained),
                                    "top1": float(d.explained and d.top.name == truth),
                                    "p_top": d.top.probability if d.explained else 0.0,
                                    "stored": st["stored"], "held": st["held"],
                                    "width": _width(st)})
    out: dict[str, Any] = {"visits": n}
    for sname, rs in rows.items():
        out[sname] = _figures(sname, rs)
    if tell:
        print("  the same visits, each record stating calibration_share 1:")
        out["stated"] = {sname: _figures(sname, rs) for sname, rs in told.items()}
    return out


def shared_commissioning(seeds: int, rng: np.random.Generator) -> dict[str, Any]:
    """Commissioning from six healthy records (three loads, 35 and 55 °C) of a rig built
    off its document (:func:`benchmarks.accuracy_cases.misspecified_rig`, as the
    commissioning suite draws it) whose instruments share one error each per visit
    (:class:`VisitInstruments`), commissioned as independent records and stating
    ``calibration_share`` 1: the share of pinned parameters whose 95 % interval holds the
    truth, and their median width in ln θ.  Prints two lines."""
    docs = {"preset": reference_rig_document(), "differential": differential_document()}
    rows: dict[str, list[tuple[float, float]]] = {"independent": [], "stated": []}
    for k in range(seeds):
        rname = ("preset", "differential")[k % 2]
        model = load_rig(docs[rname])
        actual, factors = misspecified_rig(docs[rname], rng)
        visit = VisitInstruments(rng)
        records = []
        for load in JOINT_LOADS:
            for temp in (35.0, 55.0):
                tr = transient_readings(actual, {}, load, temp)
                if tr.stalled:
                    continue
                sl, st = visit.stated(load, temp)
                cond = OperatingCondition.from_readings({"oil_temperature": st,
                                                         "load_force": sl})
                records.append(MeasurementRecord.from_readings(
                    "commission", cond, visit.read(tr.values, (*JOINT_SETS["full"],
                                                               "pump_flow"))))
        for key, share in (("independent", 0.0), ("stated", 1.0)):
            fit = commission(model, [replace(r, calibration_share=share) for r in records])
            rows[key] += [(float(p.low <= p.before * factors[p.name] <= p.high),
                           math.log(p.high / p.low)) for p in fit.parameters if p.identifiable]
    out: dict[str, Any] = {"seeds": seeds}
    for key, rs in rows.items():
        out[key] = {"pinned": len(rs), "held": float(np.mean([h for h, _ in rs])),
                    "median_ln_width": float(np.median([w for _, w in rs]))}
        print(f"  commissioning, {key:11s}: {out[key]['held']:.3f} of {len(rs)} pinned "
              f"parameters' intervals hold the truth (median width "
              f"{out[key]['median_ln_width']:.3f} in ln θ)")
    return out


def _width(st: dict[str, Any]) -> float:
    """The stored interval's width relative to its estimate [-] (NaN where none)."""
    if not st["stored"]:
        return float("nan")
    return float((st["high"] - st["low"]) / st["value"])


def _figures(sname: str, rs: list[dict[str, float]]) -> dict[str, float]:
    """One sensor set's figures (module docstring), printed on one line."""
    held = [r["held"] for r in rs if r["stored"]]
    widths = [r["width"] for r in rs if r["stored"]]
    fig = {"not_explained": 1.0 - float(np.mean([r["explained"] for r in rs])),
           "top1": float(np.mean([r["top1"] for r in rs])),
           "mean_p_top": float(np.mean([r["p_top"] for r in rs])),
           "stored": float(np.mean([r["stored"] for r in rs])),
           "stored_held": float(np.mean(held)) if held else float("nan"),
           "median_width": float(np.median(widths)) if widths else float("nan")}
    print(f"  {sname:16s} not explained {fig['not_explained']:.3f}, top-1 "
          f"{fig['top1']:.3f} (its stated probability {fig['mean_p_top']:.3f} on average), "
          f"the truth's component stored {fig['stored']:.3f}, its "
          f"95 % interval holds the truth {fig['stored_held']:.3f} (median width "
          f"{100 * fig['median_width']:.2f} % of the estimate)")
    return fig


def main(argv: list[str] | None = None) -> None:
    """``python -m benchmarks.accuracy_joint [N] [SEED] [--independent]``: N visits (default
    120) whose records share their instruments' errors (``--independent``: do not), each
    diagnosed as independent and stating ``calibration_share`` 1; the figures as JSON on
    the last line."""
    import argparse
    import json

    from benchmarks.accuracy import stored_estimate

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("n", nargs="?", type=int, default=120)
    parser.add_argument("seed", nargs="?", type=int, default=11)
    parser.add_argument("--independent", action="store_true")
    args = parser.parse_args(argv)
    out = joint_suite(args.n, np.random.default_rng(args.seed), stored_estimate,
                      shared=not args.independent, tell=True)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
