"""What a measured cycle must carry for the discrepancy workflow: stroke labels, and the
load and oil temperature it ran at (:func:`require_cycle_records`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from diagnostics.consistency import LOAD_FRACTION
from diagnostics.cycle_readings import phases_from_position, position
from diagnostics.measurement import MAX_GAUGE_PRESSURE
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError

__all__ = ["MAX_RECORD_S", "STATED", "check_pressure_units", "require_cycle_records",
           "with_phases"]

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


def check_pressure_units(records: Sequence[SeriesRecord], area: float) -> None:
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
            out.append(dataclasses.replace(r, phase=labels))
            read.append(r.name)
        else:
            out.append(r)
    notes = ([f"no phase column in {', '.join(repr(n) for n in read)}: phases read off the "
              "position (working up to the piston's reversal, the valve taken to switch "
              "there: a few ms after it did, which biases what the build-up after the "
              "switch shows — a pressure-dependent seal friction came out 8 % low where the "
              "labels gave it 1.4 % low; log the spool command where you can)"]
             if read else [])
    return out, notes
