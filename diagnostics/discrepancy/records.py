"""What a measured cycle must carry for the discrepancy workflow: stroke labels, and the
load and oil temperature it ran at (:func:`require_cycle_records`); channels whose values
contradict their column's unit (:func:`check_pressure_units`,
:func:`check_motion_and_flow_units`); the piston speed of a position-only logger
(:func:`with_velocity`); what the channels leave unevaluated (:func:`unread_notes`)."""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt
from scipy.signal import savgol_filter

from diagnostics.consistency import LOAD_FRACTION
from diagnostics.cycle_readings import PHASE_SOURCE, phases_from_position, position
from diagnostics.discrepancy.balances import BALANCES
from diagnostics.measurement import MAX_GAUGE_PRESSURE, MIN_PRESSURE_READING
from diagnostics.timeseries import CONDITION_CHANNELS, SeriesRecord
from sim.errors import InputError

__all__ = ["LOAD_EXCESS", "MAX_RECORD_S", "STATED", "VELOCITY_WINDOW",
           "check_motion_and_flow_units", "check_pressure_units", "import_notes",
           "require_cycle_records",
           "unread_notes", "with_phases", "with_velocity"]

Arr = npt.NDArray[np.float64]

#: Longest record the workflow analyses [s]: records are resampled to 1 kHz, and a rig's
#: cycle lasts seconds to a minute; ten minutes bounds the memory of a record.
MAX_RECORD_S = 600.0

#: condition entries every measured cycle must state, with the column that states them
STATED: dict[str, str] = {"load": "load [N]", "oil_temperature": "oil_temperature [degC]"}


def require_cycle_records(records: Sequence[SeriesRecord]) -> None:
    """Raise :class:`InputError` for a record the workflow cannot compare with the rig.

    * ``field="t"``: the record lasts longer than :data:`MAX_RECORD_S` (time in ms under
      ``t [s]``).
    * ``field="phase"``: no ``phase`` column labelling its working or return stroke — the
      workflow averages, splits and re-simulates by stroke, and without the labels it
      compared the whole record to one stroke (every channel hundreds of σ off,
      "unexplained").
    * ``field="load"`` / ``"oil_temperature"``: the record does not state its load or oil
      temperature (:data:`STATED`; a constant column, the single-record export's
      ``# condition`` header, or for the temperature a logged channel; a load that varies
      within the record is refused, the rig being simulated at one load).  Every simulated
      stroke, the piston-force balance and the choice of the held-out record depend on
      them, and with the rig's nominal condition put in their place, healthy cycles at
      2.1-6.3 kN and 40-50 °C came out "unexplained" with the piston-force residual at
      0.9 % of full scale (13× the 0.07 % of the same cycles with their condition,
      50 ms means).
    """
    for r in records:
        span = float(r.t[-1] - r.t[0]) if len(r.t) else 0.0
        if span > MAX_RECORD_S:
            # a time column in ms under 't [s]' was accepted, then resampled to 4.7 million
            # samples a record at 1 kHz: the server grew to 15 GB (a modelling engineer's pass)
            raise InputError(
                f"record {r.name!r} lasts {span:,.0f} s (its time runs from {r.t[0]:.6g} to "
                f"{r.t[-1]:.6g} s), longer than the {MAX_RECORD_S:.0f} s a record of one rig "
                "cycle may last here: is the time in ms under 't [s]'? (a long log is split "
                "into cycles by a 'record' column)", field="t")
        if r.phase is None:
            raise InputError(f"record {r.name!r} has no 'phase' column labelling its "
                             "'working' and 'return' strokes (the /simulate export has one)",
                             field="phase")
        if not np.isin(r.phase, ("working", "return")).any():
            found = ", ".join(repr(str(p)) for p in np.unique(r.phase)[:5])
            raise InputError(f"the 'phase' column of record {r.name!r} holds {found}, not "
                             "'working' and 'return' (the /simulate export's labels): "
                             "relabel the strokes", field="phase")
        if "load" not in r.condition and "load" in r.channels:
            lo, hi = float(np.min(r.channels["load"])), float(np.max(r.channels["load"]))
            raise InputError(f"the load of record {r.name!r} varies ({lo:.4g} to {hi:.4g} N); "
                             "the rig is simulated at one load per record, that of the "
                             "working stroke: give it as a constant 'load [N]' column",
                             field="load")
        for key, column in STATED.items():
            if key not in r.condition and key not in r.channels:
                raise InputError(
                    f"record {r.name!r} does not state its {key.replace('_', ' ')}: add a "
                    f"'{column}' column (constant within the record; any unit of its kind) "
                    "or keep the '# condition = ...' header of a single-record /simulate "
                    "export; the rig's nominal condition is not assumed for measured data",
                    field=key)


#: A working stroke's P1·A1 beyond this many times the stated load and the seal friction
#: is a load in another unit [-] (the back-pressure and the line losses add tens of %).
LOAD_EXCESS = 5.0


def check_pressure_units(records: Sequence[SeriesRecord], area: float,
                         friction: float | None = None) -> None:
    """Raise :class:`InputError` naming a pressure channel logged in another unit than its
    column says, as ``/diagnose`` refuses such a record: one beyond any instrument of a
    hydraulic rig (:data:`~diagnostics.measurement.MAX_GAUGE_PRESSURE`: Pa under a
    ``[bar]`` label), or a working stroke's P1 below :data:`LOAD_FRACTION` of the
    pressure ``F/A1`` its stated load needs (the piston's force balance, paper 002 eq. 33:
    ``P1·A1 ≥ F`` while it moves; ``area``: A1 [m²]; bar under ``[Pa]``).  The
    workflow answered such files "unexplained … re-commission the rig" at 29,947,394 σ
    (a modelling engineer's pass)."""
    for r in records:
        for name, unit in r.units.items():
            values = r.channels.get(name)
            if unit != "Pa" or values is None or not len(values):
                continue
            top = float(np.max(np.abs(values)))
            if top > MAX_GAUGE_PRESSURE:
                raise InputError(
                    f"{name} of record {r.name!r} reaches {top:.4g} Pa, beyond any instrument "
                    "of a hydraulic rig: is it in Pa (or kPa) under a [bar] label?", field=name)
            if top < MIN_PRESSURE_READING:
                # every pressure of a cycle passes 0.1 bar somewhere: P2 drives the return
                # stroke (P2 in bar under [Pa] ran to "unexplained" at 2.9e6 σ)
                raise InputError(
                    f"{name} of record {r.name!r} never reaches 0.1 bar over the cycle (at "
                    f"most {top:.4g} Pa): is it in bar (or another unit) under a [Pa] label?",
                    field=name)
        load = r.condition.get("load")
        if not load or load <= 0 or "P1" not in r.channels or r.phase is None:
            continue
        working = r.phase == "working"
        if not working.any():
            continue
        p1 = float(np.median(r.channels["P1"][working]))
        needed = load / area
        if p1 < LOAD_FRACTION * needed:
            raise InputError(
                f"P1 of record {r.name!r} reads {p1:.4g} Pa over its working stroke (median), "
                f"less than {LOAD_FRACTION:g} × the {needed:.4g} Pa that push its {load:.4g} N "
                "load (F/A1): is it in bar (or another unit) under a [Pa] label?", field="P1")
        v = r.channels.get("v")
        if friction is None or v is None:
            continue
        # while the piston moves (a dwell at the stop holds P1 at the relief setting)
        moving = working & (np.abs(v) > 1e-3)
        if moving.sum() < 10:
            continue
        push = float(np.median(r.channels["P1"][moving])) * area
        if push > LOAD_EXCESS * (load + friction):
            # a load in kN under [N]: 2.1 "N" beside a P1 that pushes 2.2 kN (the piston's
            # force balance, paper 002 eq. 33: P1·A1 − P2·A2 = F + Ffc + m·ẍ)
            raise InputError(
                f"the stated load of record {r.name!r}, {load:.4g} N, is far below what its "
                f"P1 pushes while the piston extends ({push:.4g} N = P1·A1, median; the "
                f"seal's friction is {friction:.4g} N): is the load in kN (or another unit) "
                "under [N]?", field="load")


def with_phases(records: Sequence[SeriesRecord], stroke: float
                ) -> tuple[list[SeriesRecord], list[str]]:
    """``records`` with the phases of any logged without them read off the piston's
    position, as a diagnosis of the cycle reads them
    (:func:`diagnostics.cycle_readings.phases_from_position`: working up to the piston's
    reversal, the record taken to start with the working stroke), and a note naming those
    records; ``stroke`` [m].  A logger that records the position but not the spool command
    was refused by the workflow while its cycle could be diagnosed.  Records without a
    position or speed channel are left as they are (:func:`require_cycle_records` names
    them)."""
    out: list[SeriesRecord] = []
    read: list[str] = []
    for r in records:
        if r.phase is None and ("x" in r.channels or "v" in r.channels):
            labels = phases_from_position(r, position(r), stroke)
            out.append(dataclasses.replace(r, phase=labels,
                                           metadata={**r.metadata, PHASE_SOURCE: "position"}))
            read.append(r.name)
        else:
            out.append(r)
    notes = ([f"no phase column in {', '.join(repr(n) for n in read)}: phases read off the "
              "position (working up to the piston's reversal, a few ms after the valve "
              "switched: the model's return is compared from its own reversal on, and the "
              "pressure build-up between switch and reversal counts as working stroke, so "
              "an effect that shows there is seen less well; log the spool command where "
              "you can)"]
             if read else [])
    return out, notes


#: Savitzky-Golay window of a piston speed derived from a logged position [s] (cubic, the
#: window :func:`~diagnostics.discrepancy.signals.prepare` smooths every signal with).
VELOCITY_WINDOW = 0.041


def _runs(phase: np.ndarray | None, n: int) -> list[tuple[int, int]]:
    """Index ranges ``[a, b)`` of constant phase (the whole record without phases)."""
    if phase is None or n == 0:
        return [(0, n)]
    cuts = [0, *(np.flatnonzero(phase[1:] != phase[:-1]) + 1).tolist(), n]
    return list(itertools.pairwise(cuts))


def with_velocity(records: Sequence[SeriesRecord]) -> tuple[list[SeriesRecord], list[str]]:
    """``records`` with the piston speed ``v`` [m/s] of those that log the position ``x``
    alone (a linear encoder, the usual sensor) derived from it — a cubic Savitzky-Golay
    derivative over :data:`VELOCITY_WINDOW`, within each phase (never across the valve's
    switch) — and a note naming them.  Three of the four balances need ``v``: without it a
    seal worn from 83 to 100 µm, 16 mm (160 σ) behind at the stroke's end, read "no effect"
    (a simulation engineer's pass)."""
    out: list[SeriesRecord] = []
    made: list[str] = []
    for r in records:
        if "v" in r.channels or "x" not in r.channels or r.t.size < 3:
            out.append(r)
            continue
        x = np.asarray(r.channels["x"], dtype=np.float64)
        dt = float(np.median(np.diff(r.t)))
        w = max(5, round(VELOCITY_WINDOW / dt) | 1)
        v = np.zeros_like(x)
        for a, b in _runs(r.phase, x.size):
            if b - a >= w:
                v[a:b] = savgol_filter(x[a:b], w, 3, deriv=1, delta=dt)
            elif b - a >= 2:
                v[a:b] = np.gradient(x[a:b], r.t[a:b])
        out.append(dataclasses.replace(r, channels=r.channels | {"v": v},
                                       units=r.units | {"v": "m/s"},
                                       metadata=dict(r.metadata or {}) | {"derived": ["v"]}))
        made.append(r.name)
    notes = ([f"no piston speed 'v' in {', '.join(repr(n) for n in made)}: derived from the "
              f"position x (cubic Savitzky-Golay derivative over {VELOCITY_WINDOW * 1e3:.0f} ms "
              "within each phase), so the piston balances and the held-out speed are "
              "compared"] if made else [])
    return out, notes


#: A flow channel whose 99th percentile passes this many times the pump's geometric
#: delivery is in another unit than its column says [-] (a switch's transient reaches ~3×).
FLOW_SLIP_FACTOR = 10.0
#: A position beyond this many strokes is in another unit than its column says [-].
POSITION_SLIP_FACTOR = 3.0


def check_motion_and_flow_units(records: Sequence[SeriesRecord], *, stroke: float,
                                delivery: float) -> None:
    """Raise :class:`InputError` naming a flow, position or speed channel that its own
    column contradicts: a flow meter beyond :data:`FLOW_SLIP_FACTOR` × the pump's
    geometric delivery ``delivery`` = ω·Vp [m³/s] (paper 002 eq. 2; l/min under
    ``[m^3/s]``: 60,000×), a position beyond :data:`POSITION_SLIP_FACTOR` strokes
    ``stroke`` [m] (mm under ``[m]``), a working stroke whose piston speed is mostly
    negative (the sign flipped: the working stroke extends the piston), a flow meter of the
    wrong sign (:func:`_check_flow_signs`).  The workflow ran such files and answered
    "unexplained … re-commission the rig" at 10⁵-10⁶ σ, or re-fitted the clearances first
    (a simulation engineer's pass)."""
    for r in records:
        for name in ("Q_meter_B", "Q_meter_C"):
            q = r.channels.get(name)
            if q is None or not len(q):
                continue
            top = float(np.percentile(np.abs(q), 99))
            if top > FLOW_SLIP_FACTOR * delivery:
                raise InputError(
                    f"{name} of record {r.name!r} reaches {top:.4g} m³/s, "
                    f"{top / delivery:,.0f} × the pump's geometric delivery "
                    f"({delivery:.4g} m³/s): is it in l/min (or another unit) under a "
                    "[m^3/s] label?", field=name)
        x = r.channels.get("x")
        if x is not None and len(x):
            reach = float(np.max(np.abs(x)))
            if reach > POSITION_SLIP_FACTOR * stroke:
                raise InputError(
                    f"x of record {r.name!r} reaches {reach:.4g} m where the rig's stroke is "
                    f"{stroke:.4g} m: is it in mm under an [m] label?", field="x")
        v = r.channels.get("v")
        if v is not None and r.phase is not None:
            working = v[r.phase == "working"]
            moving = working[np.abs(working) > 1e-3]
            if moving.size >= 10 and float(np.median(moving)) < 0:
                derived = "v" in (r.metadata or {}).get("derived", ())
                what = ("x of record {!r} falls through its working stroke (its derived "
                        "speed's median {:.4g} m/s)" if derived else
                        "v of record {!r} is negative through its working stroke (median "
                        "{:.4g} m/s)").format(r.name, float(np.median(moving)))
                raise InputError(
                    f"{what}, which extends the piston: is the "
                    f"{'position' if derived else 'speed'}'s sign flipped (or the phases "
                    "swapped)?", field="x" if derived else "v")
        if v is not None:
            _check_flow_signs(r, v)


def _check_flow_signs(r: SeriesRecord, v: Arr) -> None:
    """Refuse a flow meter whose sign its own column contradicts while the piston moves:
    meter B carries the pump's delivery to the valve (ω·Vp less the leaks, paper 002 eq. 2:
    positive in both strokes), meter C the oil chamber 2 exchanges with the valve (A2·ẋ,
    eq. 34: the piston speed's sign).  A flipped meter C was run and answered "unexplained"
    at 960 σ (a simulation engineer's pass)."""
    moving = np.abs(v) > 1e-3
    if int(moving.sum()) < 10:
        return
    for name, sign, says in (
            ("Q_meter_B", np.ones_like(v), "is negative while the piston moves, where it "
             "carries the pump's delivery to the valve"),
            ("Q_meter_C", np.sign(v), "flows against the piston's motion, where it carries "
             "the oil chamber 2 exchanges with the valve (A2·ẋ)")):
        q = r.channels.get(name)
        if q is None:
            continue
        along = q[moving] * sign[moving]
        if float(np.median(along)) < 0:
            raise InputError(f"{name} of record {r.name!r} {says} (median "
                             f"{float(np.median(q[moving])):.4g} m³/s): is its sign flipped?",
                             field=name)


def unread_notes(records: Sequence[SeriesRecord], evaluated: Sequence[str],
                 outputs: Sequence[str]) -> list[str]:
    """Notes naming the balances the records' channels do not allow (and the channels they
    lack) and the channels the workflow does not read (``evaluated``: the balances it
    evaluated; ``outputs``: the channels it compares with the simulation).  A healthy file whose P1 column was
    named 'P_A' was checked on the pump balance alone and answered "no effect" without a
    word (a simulation engineer's pass)."""
    have = set(records[0].channels)
    notes = []
    # the hose balance needs a pressure at the valve's B port that few rigs log: not named
    lacking = {b.name: [c for c in b.channels if c not in have and "." not in c]
               for b in BALANCES if b.name not in evaluated and b.name != "hose_pressure"}
    missing = {name: cs for name, cs in lacking.items() if cs}
    if missing:
        notes.append("not evaluated for want of a channel: " + "; ".join(
            f"{name} (no {', '.join(cs)})" for name, cs in missing.items())
            + " — an answer of no effect covers only the balances evaluated")
    known = set(outputs) | {"x", *(c for b in BALANCES for c in b.channels)}
    have -= set(CONDITION_CHANNELS)  # the stated condition, read as such
    unread = sorted(have - known)
    if unread:
        notes.append(f"channel(s) {', '.join(repr(c) for c in unread)} not read: the workflow "
                     f"reads {', '.join(sorted(known - {'hose.int_dp'}))} (name a column so, "
                     "or map it with a column map)")
    return notes


def import_notes(records: Sequence[SeriesRecord], values: Mapping[str, float]) -> list[str]:
    """The unit and sign checks the workflow refuses a cycle by (:func:`check_pressure_units`,
    :func:`check_motion_and_flow_units`, a load that varies), as notes on an import: the
    import stored bar under ``[Pa]``, l/min under ``[m^3/s]``, kN under ``[N]``, a flipped
    meter or a ramping load without a word, and the cycle read back as a record with
    p1 = 12.7 Pa (a discrepancy pass).  ``values``: the rig's (``cylinder.A1``,
    ``cylinder.Fu``, ``cylinder.stroke``, ``pump.speed``, ``pump.Vp``)."""
    try:
        labelled, _ = with_phases(records, values["cylinder.stroke"])
        labelled, _ = with_velocity(labelled)
    except InputError:  # records too short for a derived speed: the clock's notes say so
        labelled = list(records)
    notes = []
    for r in labelled:
        try:
            if "load" not in r.condition and "load" in r.channels:
                lo, hi = float(np.min(r.channels["load"])), float(np.max(r.channels["load"]))
                raise InputError(f"the load of record {r.name!r} varies ({lo:.4g} to {hi:.4g} "
                                 "N); a cycle is read at one stated load: give it as a "
                                 "constant 'load [N]' column", field="load")
            check_pressure_units([r], values["cylinder.A1"], values.get("cylinder.Fu"))
            check_motion_and_flow_units([r], stroke=values["cylinder.stroke"],
                                        delivery=values["pump.speed"] * values["pump.Vp"])
        except InputError as exc:
            notes.append(f"{exc.message} (stored as given: the discrepancy workflow and "
                         "/diagnose refuse the record until it is imported corrected)")
    return notes
