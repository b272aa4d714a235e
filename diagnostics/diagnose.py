"""Diagnose a rig from one or several measurement records: the library's front door.

``diagnose(rig, records)`` validates the records against the rig, ranks the fault
hypotheses (:mod:`diagnostics.ranking`), states what the sensors cannot separate
(:mod:`diagnostics.isolability`), adds the closed-form equivalent clearances of paper 002
§2.7 where the record carries the flows (:mod:`diagnostics.inversion`) and, when the
record has a velocity ratio but not both speeds, the ratio index
(:mod:`diagnostics.ratio_index`).  The result converts to plain JSON with units.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from weakref import WeakKeyDictionary

import numpy as np
import numpy.typing as npt

from diagnostics.condition_interval import check_singles, widen
from diagnostics.consistency import slow_stroke_notes
from diagnostics.diagnose_args import check_arguments
from diagnostics.diagnosis_result import BLIND_NOTE, Diagnosis, plain
from diagnostics.evidence_at_fit import evidence_at_fit
from diagnostics.goodness import goodness_of_fit
from diagnostics.healthy_end import healthy_end_estimates
from diagnostics.hypotheses import PARAMETERS, FaultParameter
from diagnostics.inversion import LeakageGeometry, cylinder_clearance, valve_clearance
from diagnostics.isolability import isolability
from diagnostics.measurement import MeasurementRecord
from diagnostics.observations import RecordObservations, observe, rig_limits
from diagnostics.ranking import HypothesisFit, Method, ParameterEstimate, Ranker
from diagnostics.ratio_index import RatioIndex, ratio_index
from diagnostics.shared_errors import sharing
from diagnostics.signatures import OBSERVABLES, SignatureMaps
from diagnostics.slip import rig_slip_coefficient
from diagnostics.uncertainty import Estimate
from diagnostics.unit_mistakes import unit_mistakes
from sim.errors import MeasurementError, SimulationError
from sim.rigs import Rig
from sim.units import quantity_text

__all__ = ["BLIND_NOTE", "CLEARANCES", "Diagnosis", "diagnose", "leakage_geometry", "plain", "regime_notes"]


def leakage_geometry(rig: Rig) -> LeakageGeometry:
    """The leakage-path geometry of ``rig`` for the closed-form inversions."""
    v = rig.values()
    return LeakageGeometry(bore=v["cylinder.bore"], Lc=v["cylinder.Lc"], A1=v["cylinder.A1"],
                           A2=v["cylinder.A2"], Dv=v["valve.Dv"], Ls=v["valve.Ls"],
                           stroke=v["cylinder.stroke"], Vp=v["pump.Vp"], speed=v["pump.speed"],
                           PRpv=v["supply_line.dp"], PRvt=v["valve.PRvt"])


#: oil temperatures at which the diagnosis is checked by the accuracy study (its records
#: span 20-70 °C, the property test over random rigs 20-80 °C) [°C]
CHECKED_TEMPERATURES = (20.0, 80.0)

def _direct(rig: Rig, records: Sequence[MeasurementRecord], notes: list[str]
            ) -> dict[str, Estimate]:
    """The closed-form clearances of paper 002 §2.7 (``"cc"``, ``"cv"``): on a joint visit
    that of the record whose inversion is the most precise (least standard uncertainty;
    the first of equals), so the answer and what the history keeps do not depend on the
    order the records are listed in (the first record's was kept until 2026-12-01: three
    records of different wear stored cv 60 µm forwards and 34 µm reversed)."""
    geom = leakage_geometry(rig)
    fluid = rig.spec.fluid_model()   # the rig's oil: the default VG 46 read 34 µm for 30 µm on
    out: dict[str, Estimate] = {}    # a VG 32 rig, and the trend kept it (a rig author's pass)
    joint = len(records) > 1
    reference = rig.values()["cylinder.cc"]  # the root nearer it, where two give the bypass
    for key, needs in (("cc", ("flow_C", "p1", "p2")), ("cv", ("flow_B", "flow_C",
                                                               "pump_pressure"))):
        found: list[tuple[float, int, Estimate]] = []
        for k, rec in enumerate(records):
            if any(getattr(rec, n) is None for n in needs):
                continue
            try:
                est = (cylinder_clearance(rec, geom, fluid=fluid, method="delta",
                                          reference=reference)
                       if key == "cc" else valve_clearance(rec, geom, fluid=fluid,
                                                           method="delta"))
            except MeasurementError as exc:
                where = f" from record {k + 1}" if joint else ""
                notes.append(f"direct inversion of {key}{where} not possible: {exc}")
                continue
            found.append((est.u if math.isfinite(est.u) else math.inf, k, est))
        if not found:
            continue
        _, k, out[key] = min(found, key=lambda f: (f[0], f[1]))
        if joint:  # a joint visit's page showed another record beside it
            notes.append(f"the direct inversion of {key} (paper 002 §2.7) is that of "
                         f"record {k + 1} of the {len(records)}, the most precise of the "
                         f"{len(found)} with {', '.join(needs)}; the hypothesis fits use "
                         "all of them")
    return out


def _ratio(rig: Rig, obs: Sequence[RecordObservations]) -> RatioIndex | None:
    """The ratio index of the record whose velocity ratio is the most precise (least
    relative uncertainty; the first of equals): on a joint visit, whatever the records'
    order (the first record's until 2026-12-01)."""
    found = []
    for k, o in enumerate(obs):
        q = o.record.ratio() if "velocity_ratio" in o.names else None
        if q is not None:
            found.append((q.u / abs(q.value) if q.value else math.inf, k, o, q))
    if not found:
        return None
    _, _, o, q = min(found, key=lambda f: (f[0], f[1]))
    return ratio_index(rig, o.condition, q)


def _visit_temperature(records: Sequence[MeasurementRecord]) -> float:
    """The oil temperature at which a visit's slip coefficient is stated: the mean of its
    records' [°C] (the first record's until 2026-12-01: Cs ∝ μ(T), so a visit listed in
    another order stored another Cs)."""
    return float(np.mean([r.condition.oil_temperature.value for r in records]))


def diagnose(rig: Rig, records: Sequence[MeasurementRecord], *, model_rel: float = 0.002,
             method: Method | None = None) -> Diagnosis:
    """Diagnose ``rig`` from ``records`` (jointly).

    ``method`` chooses how the hypotheses are fitted (:class:`~diagnostics.ranking.Ranker`):
    ``"fast"`` (compiled, the default) or ``"direct"``.

    Raises
    ------
    InputError
        ``rig`` is no compiled rig (``field="rig"``), an unknown ``method``
        (``field="method"``, naming the known ones).
    MeasurementError
        A record is impossible on this rig, carries nothing usable, or is no
        :class:`MeasurementRecord` (``field="records[i]"``).
    CircuitError
        The rig's circuit has no cylinder cycle.
    """
    method = check_arguments(rig, records, model_rel, method)
    rig.require_cycle("a diagnosis")
    obs = []
    limits = rig_limits(rig)  # once: the records' checks and the slow-stroke notes
    for i, rec in enumerate(records):
        try:
            obs.append(observe(rec, rig, limits=limits))
        except MeasurementError as exc:
            prefix = f"records[{i}]" if len(records) > 1 else ""
            # an error of the record as a whole names the record (``records`` when alone)
            field_path = ".".join(x for x in (prefix, exc.field or "") if x)
            raise MeasurementError(exc.message, field=field_path or "records") from None
    try:
        ranker = Ranker(rig, obs, model_rel, method)
    except SimulationError as exc:
        raise MeasurementError(
            "the rig has no steady operating point at this condition even when healthy "
            f"(neither moving nor held on its end stop): {exc}; check the load and oil "
            "temperature against the rig", field="condition") from None
    fits = ranker.rank()
    checks = check_singles(ranker, fits)
    at_fit = evidence_at_fit(ranker, fits, checks)
    iso = isolability(ranker, fits, model_rel, checks.chi2)
    single_sigma = checks.reading_sigma()
    gof = goodness_of_fit(ranker, fits, at_fit=checks.chi2, at_fit_sigma=single_sigma,
                          mistakes=lambda: unit_mistakes(rig, records, model_rel, method,
                                                         limits))
    notes: list[str] = []
    direct = _direct(rig, records, notes)
    _root_for_the_answer(direct, fits, rig)
    ratio = _ratio(rig, obs)
    _widen(ranker, fits, {}, {**{name: [sd] for name, sd in checks.sigma.items()},
                              **at_fit.pair_sigma})
    profiled = _healthy_end(ranker, fits, direct, joint=len(records) > 1)
    _widen(ranker, [], profiled)
    slip = None
    pump = next(f for f in fits if f.name == "pump")
    if pump.observable:
        (est,) = [profiled["pump"]] if "pump" in profiled else pump.parameters
        theta = _visit_temperature(records)
        slip = tuple(rig_slip_coefficient(rig, theta, k) for k in (est.value, est.low, est.high))
    n = sum(len(o.names) for o in obs)
    notes.extend(_temperature_notes(rig, records))
    notes.extend(_share_notes(records))
    notes.extend(n for r in records for n in slow_stroke_notes(r, limits))
    if not math.isfinite(fits[0].log_evidence):
        notes.append("no hypothesis explains the records")
    if not gof.confident:
        notes.append(gof.statement)
    if not any(f.observable for f in fits if f.hypothesis.components) and gof.explained:
        # not where nothing fits: "smaller uncertainties" is no advice to readings that
        # contradict the model (a verification pass)
        notes.append(BLIND_NOTE)
    return Diagnosis(rig.spec.name, fits, iso, direct, ratio,
                     slip if slip is None else (slip[0], slip[1], slip[2]), len(records), n,
                     notes, gof, regime_notes(ranker), profiled,
                     _reading_sigma(ranker, fits[0].name,
                                    {**single_sigma, **at_fit.pair_reading_sigma}))


def _share_notes(records: Sequence[MeasurementRecord]) -> list[str]:
    """What a stated ``calibration_share`` did (:mod:`diagnostics.shared_errors`)."""
    shares = [r.calibration_share for r in records]
    if not any(shares):
        return []
    if not sharing(shares):
        return ["calibration_share counts between the records of a joint diagnosis that "
                "state it (an instrument error they share); "
                + ("one record has no other to share it with" if len(records) == 1 else
                   "one record alone states it here") + ": nothing changed"]
    return ["the intervals count the instruments' errors the records share (calibration_share "
            + ", ".join(f"{f:g}" for f in shares) + "); the probabilities take the records "
            "as independent"]


def _temperature_notes(rig: Rig, records: Sequence[MeasurementRecord]) -> list[str]:
    """A note for each oil temperature outside :data:`CHECKED_TEMPERATURES` (a user pass:
    −10 °C and 95 °C were answered without a word)."""
    lo, hi = CHECKED_TEMPERATURES
    fl = rig.fluid
    out = []
    for theta in sorted({float(r.condition.oil_temperature.value) for r in records}):
        if not lo <= theta <= hi:
            inside = min(fl.T1, fl.T2) <= theta <= max(fl.T1, fl.T2)
            out.append(
                f"oil temperature {theta:g} °C is outside {lo:g}-{hi:g} °C, where the "
                "diagnosis is checked (make accuracy)"
                + ("" if inside else
                   "; the oil's viscosity law (ASTM D341 through "
                   f"{fl.nu1 * 1e6:g} cSt at {fl.T1:g} °C and {fl.nu2 * 1e6:g} cSt at "
                   f"{fl.T2:g} °C) is extrapolated there"))
    return out


def _reading_sigma(ranker: Ranker, top: str, at_estimate: dict[str, list[npt.NDArray[np.float64]]]
                   ) -> list[dict[str, float]]:
    """Per record, each reading's σ as the likelihood of the most probable hypothesis
    ``top`` weighs it: with the stated condition at its estimate where that was computed
    (:mod:`diagnostics.evidence_at_fit`), else the ranking's [SI unit of the reading]."""
    sigmas = at_estimate.get(top) or [m.sigma for m in ranker.models]
    return [{n: float(u) for n, u in zip(m.obs.names, s, strict=True)}
            for m, s in zip(ranker.models, sigmas, strict=True)]


def _widen(ranker: Ranker, fits: list[HypothesisFit], profiled: dict[str, ParameterEstimate],
           sigma: Mapping[str, Sequence[float] | npt.NDArray[np.float64]] | None = None
           ) -> None:
    """The stated conditions' uncertainty at the estimate in the intervals of the fits
    ``sigma`` holds each parameter's σ_z for (by name: the singles',
    :mod:`diagnostics.condition_interval`, the pairs', :mod:`diagnostics.evidence_at_fit`)
    and of the profiles."""
    items = []
    sigmas: list[float] = []
    for f in fits:
        if sigma is None or f.name not in sigma:
            continue
        for est, sd in zip(f.parameters, sigma[f.name], strict=True):
            p = PARAMETERS[est.name]
            lo, hi = p.worn_bounds(ranker.rig)
            items.append((p, est, p.to_z(lo), p.to_z(hi)))
            sigmas.append(float(sd))
    if items:
        widen(ranker, items, sigmas)
    items = []
    for est in profiled.values():
        p = PARAMETERS[est.name]
        items.append((p, est, p.to_z(est.nominal), p.to_z(p.worn_bounds(ranker.rig)[1])))
    widen(ranker, items)


#: single-fault hypotheses whose parameter is a component's equivalent clearance, by the
#: key of its closed-form inversion in :attr:`Diagnosis.direct` (paper 002 §2.7) [m]
CLEARANCES = {"cylinder": "cc", "valve": "cv"}


def _root_for_the_answer(direct: dict[str, Estimate], fits: list[HypothesisFit], rig: Rig
                         ) -> None:
    """Where two seal clearances give the record's bypass (:func:`~diagnostics.inversion.
    cylinder_clearance`: the root nearer the rig's clearance first), the one in the
    cylinder's worn range when the diagnosis finds the cylinder likely worn (p ≥ 0.5, alone
    or in a pair): the nearer root read a 200 µm seal at −20 °C as 75.8 µm while the
    diagnosis named the cylinder (a verification pass).  The interval spans both either
    way."""
    est = direct.get("cc")
    other = None if est is None else est.derived.get("other_root")
    if est is None or other is None:
        return
    worn = sum(f.probability for f in fits if "cylinder" in f.hypothesis.components
               and math.isfinite(f.probability))
    start = PARAMETERS["cc"].worn_bounds(rig)[0]
    if worn >= 0.5 and est.value < start <= other:
        notes = tuple(n.replace("the one nearer the rig's", "the one in the worn range, the "
                                "diagnosis finding the cylinder worn (rather than nearer the "
                                "rig's")
                      .replace(" µm is the value,", " µm) is the value,")
                      for n in est.notes)
        direct["cc"] = replace(est, value=other, notes=notes,
                               derived={**est.derived, "other_root": est.value})


def _healthy_end(ranker: Ranker, fits: list[HypothesisFit], direct: dict[str, Estimate], *,
                 joint: bool = False) -> dict[str, ParameterEstimate]:
    """:func:`diagnostics.healthy_end.healthy_end_estimates` of the observable single-fault
    fits whose component has no closed-form inversion here, or of all of them on a joint
    visit (``joint``), whose history keeps the fits of all its records rather than one
    record's closed form: a healthy visit at three loads stored its valve at the worn
    range's start, 37.39 µm [37.39, 38.60] for 34 (an edge pass)."""
    return healthy_end_estimates(ranker, [
        f for f in fits if f.observable and len(f.hypothesis.components) == 1
        and (joint or CLEARANCES.get(f.name) not in direct)])


def regime_notes(ranker: Ranker) -> list[str]:
    """Statements of the end-stop states (a stalled stroke, modelled: :mod:`sim.steady`)
    and of the values without prediction (masked) the maps met."""
    out: list[str] = []
    for i, m in enumerate(ranker.models):
        where = f"record {i}: " if len(ranker.models) > 1 else ""
        idx = tuple(int(k) for k in m.idx)
        kept = _NOTES.setdefault(m.maps, {})
        if idx not in kept:  # the notes follow from the maps and the readings' columns
            kept[idx] = _map_notes(m.maps, m.idx)
        out += [where + note for note in kept[idx]]
    return out


#: per signature maps (one condition), their regime notes by the readings' columns
_NOTES: WeakKeyDictionary[SignatureMaps, dict[tuple[int, ...], list[str]]] = (
    WeakKeyDictionary())


def _span(p: FaultParameter, z: npt.NDArray[np.float64]) -> str:
    """``"244.3 µm to 332 µm"``: the span of fitting coordinates ``z`` in ``p``'s values
    (:func:`~sim.units.quantity_text`: a clearance in µm)."""
    return (f"{quantity_text(p.from_z(float(z.min())), p.unit)} to "
            f"{quantity_text(p.from_z(float(z.max())), p.unit)}")


def _map_notes(maps: SignatureMaps, idx: npt.NDArray[np.int64]) -> list[str]:
    """:func:`regime_notes` of one condition's maps for readings of columns ``idx``."""
    out: list[str] = []
    iw, ir = OBSERVABLES.index("speed_work"), OBSERVABLES.index("speed_return")
    nominal = maps.nominal
    if nominal[iw] == 0.0:
        out.append("the healthy rig's working piston sits on its end stop at this "
                   "condition (load at or above what it can push): predicted in its "
                   "end-stop state, speed 0")
    if nominal[ir] == 0.0:
        out.append("the healthy rig's return stroke sits on its end stop at this "
                   "condition (no velocity ratio); a record's ratio is compared as "
                   "impossible")
    elif not np.isfinite(nominal).all():
        out.append("the healthy rig has no steady operating point at this "
                   "condition; readings without prediction are compared as impossible")
    # the pressures and flows are the working phase's: its stop concerns every record
    reads_return = bool(np.isin(idx, (ir, OBSERVABLES.index("velocity_ratio"))).any())
    for name, hm in maps.maps.items():
        (p,) = hm.params
        for col, phase in ((iw, "working"), (ir, "return")):
            held = hm.pred[:, col] == 0.0
            if held.any() and (phase == "working" or reads_return):
                z = hm.axes[0][held]  # from_z increases with z
                out.append(
                    f"{name}: for {p.name} from {_span(p, z)} ({held.mean():.0%} of its prior "
                    f"range) the {phase} piston sits on its end stop (stalled); predicted in "
                    "that state (speed 0, the pump's flow through the leakage paths and "
                    "over the relief valve)")
        bad = np.isnan(hm.pred[:, idx]).any(axis=1)
        if not bad.any():
            continue
        z = hm.axes[0][bad]
        out.append(
            f"{name}: for {p.name} from {_span(p, z)} ({bad.mean():.0%} of its prior range) "
            "these readings have no prediction (a velocity ratio with the return stroke on "
            "its end stop, or no steady operating point); those values are masked "
            "(excluded) in the fit")
    return out
