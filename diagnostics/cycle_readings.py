"""Readings of a measured cycle: the record ``/diagnose`` takes, from a working + return series.

A rig's logged cycle (the table ``/simulate`` exports, or a logger's through a column map,
read by :func:`diagnostics.timeseries.read_series`) becomes one measurement record, read
as the simulator reads its own phases (:mod:`sim.phase_reading`):

* a **moving stroke** (travel ≥ :data:`COMPLETED_SHARE` of the rig's stroke, or one whose
  end stop came between two samples: still moving at its last sample) is read over
  the middle 80 % of its travel: pressures and flows as time averages, the speed as the
  least-squares slope of the position there — what a linear encoder reads of the steady
  stroke, and what the steady model of the diagnosis predicts (on the reference rig, a
  worn spool at 4.2 kN, the simulated cycle's mid-stroke slope and the steady speed agree
  to 1e-6; stroke/duration, which counts the start-up, reads 0.11 % lower: 0.4 σ of the
  encoder);
* a **stalled or creeping stroke** (less travel) is read over the last half of the phase,
  the settled state: averages as above and the creep speed from the position's change
  there.  A held stroke's speed (it moved less than :data:`HELD_SHARE` of the stroke while
  settled: noise, not creep) is left out — the encoder's class is relative, so a reading
  of 0 would have no uncertainty —, and so is the return stroke's speed after a stalled
  working stroke (it starts where the piston stalled: no stroke).

Working-phase pressures and flows are the record's (:data:`CHANNELS`: ``P_pump``, ``P1``,
``P2``, ``Q_meter_B``, ``Q_meter_C``; the pump's flow from a ``Q_pump`` channel only: meter
B plus a relief flow would count meter B twice); each phase's speed is a reading and the
velocity ratio follows from them (:meth:`diagnostics.measurement.MeasurementRecord.ratio`).
A channel the series lacks is a reading the record lacks; a series without a ``phase``
column has its phases read off the position (working up to the piston's reversal, a note
says so).  The position is ``x`` [m], or
the speed ``v`` [m/s] integrated; without either the steady stroke cannot be found.  The
condition is the series' (constant condition columns or the export's header), overridden
by what the caller states; a logged oil temperature that varies is averaged over the
working stroke's window.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.channel_names import (
    PUMP_FLOW_CHANNEL,
    cycle_model_channels,
    unknown_channel_note,
    unknown_channels,
)
from diagnostics.measurement import (
    DEFAULT_INSTRUMENTS,
    InstrumentClass,
    MeasurementRecord,
    OperatingCondition,
)
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError
from sim.phase_reading import settled_window, steady_slope, steady_window, time_average

__all__ = ["CHANNELS", "COMPLETED_SHARE", "HELD_SHARE", "PHASE_SOURCE", "READ_CHANNELS",
           "CycleReadings", "PhaseReading", "cycle_readings", "phase_reading",
           "phases_from_position", "position", "reversal_delay", "unread_channel_note"]

Arr = npt.NDArray[np.float64]

#: share of the rig's stroke a phase must travel to count as a completed stroke [-]
COMPLETED_SHARE = 0.98
#: a stroke short of COMPLETED_SHARE that covered this share and still moved at its last
#: sample ended between two samples (:func:`_cut_by_sampling`) [-]
SAMPLED_SHARE = 0.9
#: a stalled stroke that moves less than this share of the stroke over its settled window
#: is held on its stop (0.05 mm on a 0.5 m stroke: a linear encoder's resolution, well
#: above a logged position's noise, below any creep the model predicts over seconds) [-]
HELD_SHARE = 1e-4
#: metadata key of a record whose phases were read off the position (value ``"position"``,
#: :func:`phases_from_position`): its return starts :func:`reversal_delay` after the valve's
PHASE_SOURCE = "phase_source"
#: record field → channel of the working phase it is read from
CHANNELS: dict[str, str] = {"pump_pressure": "P_pump", "p1": "P1", "p2": "P2",
                            "flow_B": "Q_meter_B", "flow_C": "Q_meter_C"}
#: channels averaged in each phase's window (those the record or the pump's flow needs)
_AVERAGED = (*CHANNELS.values(), PUMP_FLOW_CHANNEL, "Q_relief")
#: every channel a cycle's readings are taken from (a pump flow meter ``Q_pump`` is no
#: output of the rig's model, yet read)
READ_CHANNELS: tuple[str, ...] = (*_AVERAGED, "x", "v")
#: series condition key → record condition field
_CONDITION = {"load": "load_force", "back_pressure": "back_pressure",
              "oil_temperature": "oil_temperature", "pump_speed": "pump_speed"}
_SPEED = {"working": "speed_work", "return": "speed_return"}


@dataclass(frozen=True)
class PhaseReading:
    """One phase of a cycle as a rig reads it.

    Attributes
    ----------
    phase
        ``"working"`` or ``"return"``.
    completed
        Whether the piston travelled at least :data:`COMPLETED_SHARE` of the stroke.
    window
        First and last time of the samples read [s].
    travel
        Distance travelled in the phase [m].
    speed
        Steady speed (moving) or creep speed (stalled) [m/s].
    averages
        Channel → time average over the window [SI unit of the channel].
    """

    phase: str
    completed: bool
    window: tuple[float, float]
    travel: float
    speed: float
    averages: dict[str, float]


@dataclass(frozen=True)
class CycleReadings:
    """A cycle read as one measurement record.

    Attributes
    ----------
    name
        The series' record name.
    readings
        :class:`~diagnostics.measurement.MeasurementRecord` field → value [SI].
    condition
        Condition field of the record (``oil_temperature`` [°C], ``load_force`` [N],
        ``back_pressure`` [Pa], ``pump_speed`` [rad/s]) → value.
    phases
        The phases read, in the series' order.
    notes
        What a reader must know (a stalled stroke, a reading left out, and why).
    """

    name: str
    readings: dict[str, float]
    condition: dict[str, float]
    phases: tuple[PhaseReading, ...]
    notes: tuple[str, ...]

    def record(self, rig_id: str, *, rig_name: str | None = None,
               instruments: Mapping[str, InstrumentClass] = DEFAULT_INSTRUMENTS
               ) -> MeasurementRecord:
        """The measurement record, every reading of its default instrument class.

        Raises
        ------
        InputError
            The condition states no oil temperature, or neither load nor back-pressure.
        """
        if "oil_temperature" not in self.condition:
            raise InputError(f"cycle {self.name!r} states no oil temperature: give it (a "
                             "constant 'oil_temperature [degC]' column, the export's "
                             "condition header, or the caller's condition)",
                             field="condition.oil_temperature")
        condition = OperatingCondition.from_readings(self.condition, instruments=instruments)
        return MeasurementRecord.from_readings(rig_id, condition, self.readings,
                                               rig_name=rig_name, instruments=instruments)


def phase_reading(phase: str, t: Arr, x: Arr, channels: Mapping[str, Arr], stroke: float,
                  completed: bool | None = None, held_share: float = HELD_SHARE
                  ) -> PhaseReading:
    """Read one phase (module docstring): times ``t`` [s], positions ``x`` [m], the
    channels [SI] and the rig's ``stroke`` [m]; ``completed`` as known (a simulation's
    end-of-stroke event), else judged from the travel; ``held_share`` of the stroke, the
    least settled motion that is creep (0 for a simulated position, which resolves any)."""
    travel = float(abs(x[-1] - x[0]))
    if completed is None:
        completed = travel >= COMPLETED_SHARE * stroke or _cut_by_sampling(t, x, travel, stroke)
    sel = steady_window(x) if completed else settled_window(t)
    ts, xs = t[sel], x[sel]
    if completed:
        speed = steady_slope(ts, xs)
    else:  # held (moved less than a position sensor resolves while settled) or creeping
        span, moved = ts[-1] - ts[0], float(abs(xs[-1] - xs[0]))
        speed = moved / span if span > 0 and moved >= held_share * stroke else 0.0
    averages = {c: time_average(channels[c][sel], ts) for c in _AVERAGED if c in channels}
    return PhaseReading(phase, completed, (float(ts[0]), float(ts[-1])), travel, speed,
                        averages)


def _cut_by_sampling(t: Arr, x: Arr, travel: float, stroke: float) -> bool:
    """Whether a stroke short of :data:`COMPLETED_SHARE` was still moving at its last
    sample, at half its mid-stroke speed or more, having covered :data:`SAMPLED_SHARE` of
    the stroke: the end stop came between two samples (at 20 Hz a 0.22 m/s stroke ends up
    to 11 mm after its last sample), not a stall."""
    if travel < SAMPLED_SHARE * stroke or t.size < 4:
        return False
    sel = steady_window(x)
    end = abs(x[-1] - x[-2]) / (t[-1] - t[-2]) if t[-1] > t[-2] else 0.0
    return bool(end >= 0.5 * steady_slope(t[sel], x[sel]))


def phases_from_position(series: SeriesRecord, x: Arr, stroke: float) -> npt.NDArray[np.str_]:
    """Phase labels of a cycle logged without them (a logger that records the position but
    not the spool command), the record taken to start with the working stroke as paper
    002's cycle does: working while the piston moves away from where it started and dwells
    at its farthest point, return from the last sample there on.  One out-and-back per
    record: a record whose piston leaves its start again after coming back is several
    cycles."""
    away = np.abs(x - x[0])
    tol = HELD_SHARE * stroke
    if away.size < 4 or float(np.max(away)) < 10.0 * tol:
        raise InputError(f"cycle {series.name!r} has no 'phase' column and its piston does "
                         "not move: give the phases (working/return, or the spool command "
                         "N = +1/−1)", field="phase")
    # departures: from home (within 10 tol of the start) out past half the farthest point
    state = np.where(away <= 10.0 * tol, 0, np.where(away >= 0.5 * float(np.max(away)), 1, -1))
    marked = state[state >= 0]
    if int(np.sum((marked[1:] == 1) & (marked[:-1] == 0))) > 1:
        raise InputError(f"cycle {series.name!r} has no 'phase' column and holds more than "
                         "one out-and-back of the piston: separate the cycles with a "
                         "'record' column, or give the phases", field="phase")
    labels = np.full(x.size, "return", dtype="<U7")
    labels[: _last_far(x, stroke) + 1] = "working"
    return labels


def _last_far(x: Arr, stroke: float) -> int:
    """Index of the last sample within :data:`HELD_SHARE` × ``stroke`` of the piston's
    farthest point from where it started: the end of the working phase read off the
    position (:func:`phases_from_position`)."""
    away = np.abs(x - x[0])
    return int(np.flatnonzero(away >= float(np.max(away)) - HELD_SHARE * stroke)[-1])


def reversal_delay(t: Arr, x: Arr, phase: npt.NDArray[np.str_], stroke: float) -> float:
    """How long after its valve switch a cycle's return phase starts when read off the
    position [s]: the time from the first ``"return"`` sample of ``phase`` (the spool
    command) to the first sample :func:`phases_from_position` labels return.  A model's
    cycle gives it for a record whose phases were read off the position, so that the
    record's return is compared with the model's from the same instant (0 when ``phase``
    has no return)."""
    ret = np.flatnonzero(phase == "return")
    if ret.size == 0:
        return 0.0
    read = min(_last_far(x, stroke) + 1, t.size - 1)
    return float(t[read] - t[ret[0]])


def position(series: SeriesRecord) -> Arr:
    """The piston position [m]: ``x``, or the speed ``v`` integrated from 0."""
    if "x" in series.channels:
        return series.channels["x"]
    if "v" in series.channels:
        v, t = series.channels["v"], series.t
        steps = 0.5 * (v[1:] + v[:-1]) * np.diff(t)
        return np.concatenate([[0.0], np.cumsum(steps)])
    raise InputError(f"cycle {series.name!r} has no piston position 'x [m]' or speed "
                     "'v [m/s]': the steady stroke cannot be found without one", field="x")


def unread_channel_note(channels: Iterable[str],
                        model_channels: Collection[str] | None = None) -> str | None:
    """The note on ``channels`` a cycle's readings do not read because they are none of
    the rig's ``model_channels`` (default: the cylinder-cycle circuit's), none of
    :data:`READ_CHANNELS` and no condition, with the nearest channel for each; None when
    there are none.  :func:`cycle_readings` adds it; the CLI says it once per file."""
    model = tuple(cycle_model_channels() if model_channels is None else model_channels)
    unknown = unknown_channels(channels, (*model, *READ_CHANNELS))
    if not unknown:
        return None
    return unknown_channel_note(
        unknown, model, f"not read (a cycle's readings are taken from "
        f"{', '.join(READ_CHANNELS)}), so the record lacks what they hold; a misspelt name "
        "is read again with the column map corrected", also=READ_CHANNELS)


def cycle_readings(series: SeriesRecord, stroke: float,
                   condition: Mapping[str, float] | None = None, *,
                   model_channels: Collection[str] | None = None) -> CycleReadings:
    """The record of one cycle (module docstring).

    Parameters
    ----------
    series
        The cycle, with its ``phase`` column; without one, the phases are read off the
        position (:func:`phases_from_position`) and a note says so.
    stroke
        The rig's stroke [m].
    condition
        Condition fields (``oil_temperature`` [°C], ``load_force`` [N], ``back_pressure``
        [Pa], ``pump_speed`` [rad/s]) that override the series'.
    model_channels
        The rig model's channels (:meth:`sim.rigs.Rig.channels`); default: those of the
        cylinder-cycle circuit.  A channel of the series that is none of these, none of
        :data:`READ_CHANNELS` and no condition is not read, and a note names it with the
        nearest channel read (a column map's ``P_pmup`` dropped the pump pressure without
        a word: a library user's pass); the model's other outputs, which a simulated
        export carries, are not read either, by design, and not noted.

    Raises
    ------
    InputError
        No working/return phase in the ``phase`` column (or, without one, a piston that
        does not move or moves out and back more than once), no position or speed channel,
        a phase with fewer than two samples, an unknown condition field, or a series whose
        condition has both a load and a back-pressure.
    """
    x = position(series)
    phases: list[PhaseReading] = []
    notes: list[str] = []
    if (unread := unread_channel_note(series.channels, model_channels)) is not None:
        notes.append(unread)
    labels = series.phase
    if labels is None:
        labels = phases_from_position(series, x, stroke)
        notes.append(f"no phase column: the record taken to start with the working stroke "
                     f"(paper 002's cycle), working up to the piston's reversal at t = "
                     f"{series.t[int(np.sum(labels == 'working')) - 1]:.3f} s, return after it")
    for name in ("working", "return"):
        rows = labels == name
        if not rows.any():
            notes.append(f"no {name} phase: its readings are left out")
            continue
        if rows.sum() < 2:
            raise InputError(f"cycle {series.name!r}: the {name} phase has one sample",
                             field="phase")
        phases.append(phase_reading(name, series.t[rows], x[rows],
                                    {c: v[rows] for c, v in series.channels.items()}, stroke))
    if not phases:
        raise InputError(f"cycle {series.name!r} has no 'working' or 'return' phase",
                         field="phase")
    readings: dict[str, float] = {}
    by_name = {p.phase: p for p in phases}
    work = by_name.get("working")
    if work is not None:
        readings.update({f: work.averages[c] for f, c in CHANNELS.items() if c in work.averages})
        # a pump flow only from its own meter: meter B + the relief's flow was once added,
        # and with the relief shut that is meter B counted twice (a user pass: valve p
        # 0.89 → 0.93 on the README's simulate → series → record path)
        if "Q_pump" in work.averages:
            readings["pump_flow"] = work.averages["Q_pump"]
    for p in phases:
        if not p.completed:
            notes.append(f"the {p.phase} stroke stalled or crept ({1e3 * p.travel:.1f} mm of "
                         f"{1e3 * stroke:.1f} mm): read over the last half of the phase")
        if p.phase == "return" and work is not None and not work.completed:
            notes.append("no return speed: the return stroke starts where the working stroke "
                         "stalled")
        elif p.speed > 0.0:
            readings[_SPEED[p.phase]] = p.speed
        else:
            notes.append(f"the {p.phase} stroke is held on its end stop: no speed reading "
                         "(a speed of 0 has no uncertainty under the encoder's relative "
                         "class)")
    return CycleReadings(series.name, readings, _condition(series, labels, work, condition),
                         tuple(phases), tuple(notes))


def _condition(series: SeriesRecord, labels: npt.NDArray[np.str_], work: PhaseReading | None,
               stated: Mapping[str, float] | None) -> dict[str, float]:
    out = {_CONDITION[k]: float(v) for k, v in series.condition.items()
           if k in _CONDITION and v is not None and math.isfinite(v)}
    if "oil_temperature" in series.channels and "oil_temperature" not in out and work is not None:
        rows = labels == "working"
        t, temp = series.t[rows], series.channels["oil_temperature"][rows]
        sel = (t >= work.window[0]) & (t <= work.window[1])
        out["oil_temperature"] = time_average(temp[sel], t[sel])
    for key, value in (stated or {}).items():
        if key not in _CONDITION.values():
            raise InputError(f"unknown condition field (one of {', '.join(_CONDITION.values())})",
                             field=f"condition.{key}")
        out[key] = float(value)
    # the export states both, one of them 0 (a load, no back-pressure valve, or neither)
    if out.get("load_force") == 0.0 and out.get("back_pressure", 0.0) != 0.0:
        del out["load_force"]
    elif out.get("back_pressure") == 0.0 and "load_force" in out:
        del out["back_pressure"]
    if "load_force" in out and "back_pressure" in out:
        raise InputError("a record states the load force or the back-pressure, not both: "
                         f"the cycle has load {out['load_force']:g} N and back-pressure "
                         f"{out['back_pressure']:g} Pa acting together, which a record "
                         "cannot state (its two fields are two ways of stating one load, "
                         "paper 002 §2.7)", field="condition.back_pressure")
    return out
