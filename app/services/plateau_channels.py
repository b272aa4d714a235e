"""The channels a rig without a working/return cycle is read by — its pressure plateaus,
from the pump pressure ``p_pump`` and the working flow ``q_work``
(:func:`diagnostics.real.profile.settled_bench`) — and the checks an import of such a rig's
series gets: the unit slips their values reveal, and a note when they are missing.  Used by
:func:`app.services.series.import_series`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from app.db.models import MeasuredSeries
from diagnostics.measurement import MAX_FLOW_READING, MAX_GAUGE_PRESSURE, MIN_PRESSURE_READING
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError

__all__ = ["DELIVERY_FACTOR", "LOW_DELIVERY", "LOW_PRESSURE", "PLATEAU_CHANNELS",
           "PRESSURE_FACTOR", "check_plateau_channels", "plateau_notes", "plateau_scale_notes"]

#: The channels a rig without a cycle is read by (its plateaus: pump pressure and working
#: flow, :func:`diagnostics.real.profile.settled_bench`) and their SI units.
PLATEAU_CHANNELS: dict[str, str] = {"p_pump": "Pa", "q_work": "m^3/s"}
#: A working flow beyond this many times the pump's geometric delivery is a slip [-].
DELIVERY_FACTOR = 10.0
#: A pump pressure beyond this many times the relief setting is a slip [-].
PRESSURE_FACTOR = 2.0
#: A working flow that never reaches this share of the pump's delivery is noted [-]: l/min
#: written as cm³/s reads 1/60 of it (a real-data analyst's pass)
LOW_DELIVERY = 0.2
#: A pump pressure that never reaches this share of the relief setting is noted [-]: bar
#: written as kPa reads 1/100 of it
LOW_PRESSURE = 0.02


def plateau_notes(rows: Sequence[MeasuredSeries]) -> list[str]:
    """A note naming the plateau channels an import to a rig without a cycle lacks (the
    oil temperature too, unless stated as the record's condition), and a name that differs
    from one only in case (the model's ``P_pump`` for ``p_pump``: the column-map example of
    docs/real-data.md, then in the README, stored series the plateau reader refused) or a
    usual name for the temperature."""
    names = {c for r in rows for c in r.units}
    lacking = [c for c in PLATEAU_CHANNELS if c not in names]
    # the plateaus are read at the cycle's oil temperature: a channel or a stated condition
    if any("oil_temperature" not in r.units and "oil_temperature" not in (r.condition or {})
           for r in rows):
        lacking.append("oil_temperature")
    if not lacking:
        return []
    near = [n for n in sorted(names) if n.lower() in lacking
            or (n.lower() in ("temperature", "oil_temp", "t_oil") and "oil_temperature" in lacking)]
    hint = (f" ({', '.join(near)} is another name: channel names are case-sensitive and "
            "exact)" if near else "")
    return [f"no channel {', '.join(lacking)}: a rig without a cycle is read by its "
            f"plateaus, from {' and '.join(PLATEAU_CHANNELS)} at the oil_temperature, so the "
            f"discrepancy workflow cannot read these records{hint}; map the columns to "
            "those names"]


def check_plateau_channels(records: Sequence[SeriesRecord], delivery: float | None = None,
                           relief: float | None = None) -> None:
    """Refuse a plateau channel that its own column contradicts (the records of a rig
    without a cycle): a pump pressure that never reaches 0.1 bar (bar under ``[Pa]``: 150
    Pa stored) or twice the relief setting ``relief`` [Pa] (bar under ``[MPa]``: 1,900
    bar stored), a
    working flow beyond 1 m³/s (l/min under ``[m^3/s]``: 7.7 m³/s stored) or beyond ten
    times the pump's geometric delivery ``delivery`` = ω·Vp [m³/s] (paper 002 eq. 2; the
    pressure and flow
    columns swapped: 150 l/min from a pump of 8); a real-data analyst's pass found each
    stored without a word."""
    for r in records:
        p = r.channels.get("p_pump")
        if p is not None and len(p) and float(np.nanmax(p)) < MIN_PRESSURE_READING:
            raise InputError(f"p_pump of record {r.name!r} never reaches 0.1 bar (at most "
                             f"{float(np.nanmax(p)):.4g} Pa): is it in bar under a [Pa] "
                             "label?", field="p_pump")
        ceiling = min(MAX_GAUGE_PRESSURE, PRESSURE_FACTOR * relief) if relief else \
            MAX_GAUGE_PRESSURE
        if p is not None and len(p) and float(np.nanmax(p)) > ceiling:
            raise InputError(f"p_pump of record {r.name!r} reaches {float(np.nanmax(p)):.4g} "
                             "Pa, beyond " + (f"{PRESSURE_FACTOR:g} × the rig's relief "
                                              f"setting ({relief:.4g} Pa)" if relief else
                                              "any instrument of a hydraulic rig")
                             + ": is it in bar (or Pa) under an [MPa] (or [bar]) label?",
                             field="p_pump")
        q = r.channels.get("q_work")
        if q is None or not len(q):
            continue
        top = float(np.nanmax(np.abs(q)))
        if top > MAX_FLOW_READING:
            raise InputError(f"q_work of record {r.name!r} reaches {top:.4g} m³/s, beyond any "
                             "pump of a test rig: is it in l/min (or another unit) under an "
                             "[m^3/s] label?", field="q_work")
        if delivery and top > DELIVERY_FACTOR * delivery:
            raise InputError(f"q_work of record {r.name!r} reaches {top:.4g} m³/s, "
                             f"{top / delivery:.3g} × the rig's pump delivers ({delivery:.4g} "
                             "m³/s at its stated speed): are the pressure and flow columns "
                             "swapped, or the flow in another unit?", field="q_work")


def plateau_scale_notes(records: Sequence[SeriesRecord], delivery: float | None,
                        relief: float | None, min_duration: float = 3.0) -> list[str]:
    """Notes on records of a rig without a cycle whose plateau channels stay far below
    what the rig does — a working flow under :data:`LOW_DELIVERY` of the pump's delivery
    [m³/s], a pump pressure under :data:`LOW_PRESSURE` of the relief setting [Pa], the
    unit slips that read too small (l/min as cm³/s, bar as kPa), which
    :func:`check_plateau_channels` does not refuse since a rig may run so — and records
    shorter than a plateau (``min_duration`` [s]: a 1 Hz file imported at 100 Hz), which
    the plateau reader refuses later.  Each was stored without a word (a real-data
    analyst's pass)."""
    notes = []
    for r in records:
        q, p = r.channels.get("q_work"), r.channels.get("p_pump")
        if delivery and q is not None and len(q):
            top = float(np.nanmax(np.abs(q)))
            if top < LOW_DELIVERY * delivery:
                notes.append(f"q_work of record {r.name!r} reaches at most {top:.4g} m³/s "
                             f"({top * 6e4:.4g} l/min), {top / delivery:.2g} × the pump's "
                             f"delivery ({delivery * 6e4:.4g} l/min): is it in a smaller unit "
                             "than written (l/min under [cm^3/s])? Stored as given")
        if relief and p is not None and len(p):
            top = float(np.nanmax(p))
            if top < LOW_PRESSURE * relief:
                notes.append(f"p_pump of record {r.name!r} reaches at most {top / 1e5:.4g} "
                             f"bar, {top / relief:.2g} × the relief setting "
                             f"({relief / 1e5:.4g} bar): is it in a smaller unit than "
                             "written (bar under [kPa])? Stored as given")
        if r.duration < min_duration:
            notes.append(f"record {r.name!r} lasts {r.duration:.3g} s, shorter than a "
                         f"plateau ({min_duration:g} s): the plateau reader refuses it (a "
                         "sample rate stated too high?)")
    return notes
