"""The one call of the transient rig model used by the discrepancy workflow.

Every simulation of the workflow (residuals, output-error re-fits, held-out checks, the
hidden-effect bench) goes through :func:`simulate`: :func:`sim.cycle.run_cycle` with the
RODAS4 solver in its noise-accurate mode (error below 0.3 σ of a velocity sensor and 0.1 σ
of pressure and flow sensors, :mod:`sim.solver.noise`), sampled on a grid of
:data:`SAMPLE_RATE` from the dense output.  The error estimate it reached is kept in the
table's ``attrs["solver"]`` so the report can state the solver error relative to the noise.

A measured record is simulated by :func:`simulate_record`: under its own condition, and
with its phase switch where the record switched.  A working phase that ends at the stroke
end is switched by the end stop (the model's own event); one that ends short of it (the
``x`` channel more than :data:`TIMED_MARGIN` of the stroke away from the end) was switched
by time (a slow-motion test stroke, :func:`timed_switch`), and the model switches at the
same time.  So does one whose piston stood at the stroke end for longer than
:data:`DWELL_MIN` before the switch (a *dwell* record: the stroke runs into the stop and is
held there, the pump flow going over the relief valve, until a timer switches): the model
holds its piston at the stop until the same time (``hold`` of
:func:`sim.cycle.run_cycle`).  :func:`record_kind` names the three kinds.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy.ndimage import median_filter

from diagnostics.cycle_readings import PHASE_SOURCE, reversal_delay
from diagnostics.discrepancy.noise import Noise
from diagnostics.discrepancy.signals import condition_of
from diagnostics.timeseries import SeriesRecord
from sim.cycle import run_cycle
from sim.rigs.assembly import Condition, Rig
from sim.solver.noise import DEFAULT_NOISE

__all__ = [
    "AT_STOP",
    "DESPIKE",
    "DWELL_MIN",
    "SAMPLE_RATE",
    "SOLVER",
    "SOLVER_WELL_BELOW",
    "TIMED_MARGIN",
    "despiked",
    "model_origin",
    "model_phase_start",
    "on_grid",
    "phase_segments",
    "phase_start",
    "record_kind",
    "simulate",
    "simulate_record",
    "solver_error",
    "solver_statement",
    "timed_switch",
]

Arr = npt.NDArray[np.float64]

#: output grid of every workflow simulation, from the solver's dense output [Hz]
SAMPLE_RATE = 5000.0
#: how the workflow simulates, in words (for the report)
SOLVER = ("sim.cycle.run_cycle, RODAS4, noise-accurate (≤ 0.3 σ velocity, ≤ 0.1 σ pressure "
          "and flow, σ of its default instruments: 25 kPa, 2.33e-6 m³/s, 0.32 mm/s), dense "
          f"output at {SAMPLE_RATE:g} Hz, read between its points by linear interpolation")
#: a working phase ending farther than this fraction of the stroke from the stroke end was
#: switched by time, not by the end stop [-]
TIMED_MARGIN = 0.05
#: a piston within this distance of the stroke end is at its stop [m] (10 σ of the
#: position sensor)
AT_STOP = 1e-3
#: samples of the running median that takes isolated spikes out of a measured position [-]
DESPIKE = 5
#: a working phase whose piston stood at its stop for longer than this before the switch
#: is a dwell record [s] (an end-stop switch leaves it there for < 40 ms even at 15 %
#: pump speed)
DWELL_MIN = 0.25


def simulate(rig: Rig, condition: Condition | None = None,
             overrides: Mapping[str, float] | None = None,
             t_max: float | None = None) -> pd.DataFrame:
    """One working + return cycle as a time-series table (the ``/simulate`` export format).

    ``t_max`` [s] switches the working phase after that long (a timed stroke: one that
    reaches its stop earlier dwells there, ``hold`` of :func:`sim.cycle.run_cycle`) and
    the return phase at its stop or after that long; ``None``: the end stops switch.

    Raises
    ------
    SimulationError
        If the solver fails.
    """
    res = run_cycle(rig, overrides, condition, method="rodas4", sample_rate=SAMPLE_RATE,
                    timeseries=True, t_max=t_max, hold=t_max is not None)
    assert res.timeseries is not None
    table = res.timeseries
    table.attrs["solver"] = dict(res.solver.error_sigma or {}) if res.solver else {}
    # the switch events the solver stepped to (the grid's first return row is up to one
    # grid period later): :func:`model_phase_start`
    table.attrs["phase_start"] = {"working": 0.0,
                                  "return": float(res.working.values["duration"])}
    return table


def phase_start(times: Arr, first: int) -> float:
    """When a phase, or a segment of one, that a sampled series first shows at sample
    ``first`` began [s]: midway between that sample and the one before, or the series'
    first time for ``first`` = 0.

    The switch (or the arrival at a stop) fell somewhere between the two samples, so the
    first sample alone reads it half a sample period late on average: at 1 kHz logging a
    0.5 ms shift of the whole phase, which on noise-free records of the hidden-effect
    design left the position 0.84 σ RMS off its own model and the friction pair re-fitted
    3-6 σ off the truth.  The midpoint leaves an error uniform within ± half a period,
    with no bias (the timing floor of :func:`~diagnostics.discrepancy.gap.gap_table`).
    """
    if first <= 0:
        return float(times[0])
    return 0.5 * float(times[first - 1] + times[first])


def model_phase_start(table: pd.DataFrame, phase: str) -> float:
    """When ``phase`` of a simulated ``table`` began [s]: the switch event the solver
    stepped to (``attrs["phase_start"]``, :func:`simulate`), else as :func:`phase_start`
    on the table's rows."""
    exact = table.attrs.get("phase_start", {}).get(phase)
    if exact is not None:
        return float(exact)
    rows = np.flatnonzero(table["phase"].to_numpy(dtype=str) == phase)
    return phase_start(table["t [s]"].to_numpy(dtype=float), int(rows[0]) if rows.size else 0)


def record_kind(record: SeriesRecord, rig: Rig) -> str:
    """``"full"`` (switched by the end stop), ``"slow"`` (switched by time short of the
    stop) or ``"dwell"`` (held at the stop for longer than :data:`DWELL_MIN`, then
    switched by time); ``"full"`` without the ``x`` channel or both phases."""
    if record.phase is None or "x" not in record.channels:
        return "full"
    work = np.flatnonzero(record.phase == "working")
    ret = np.flatnonzero(record.phase == "return")
    if work.size < 2 or ret.size == 0:
        return "full"
    stroke = rig.base["cylinder.stroke"]
    x = despiked(record.channels["x"][work])
    if x[-1] < (1.0 - TIMED_MARGIN) * stroke:
        return "slow"
    away = np.flatnonzero(x < stroke - AT_STOP)
    arrival = record.t[work[away[-1] + 1]] if away.size and away[-1] + 1 < work.size \
        else record.t[work[0]]
    return "dwell" if record.t[work[-1]] - arrival > DWELL_MIN else "full"


def despiked(x: Arr) -> Arr:
    """A measured position [m] with isolated spikes removed (running median of
    :data:`DESPIKE` samples), for the tests against the stroke end: one heavy-tailed sample
    of the position sensor 1 mm off during a dwell made a dwell record a full stroke
    (measured with t₃ noise: the held-out dwell then simulated as a stroke switched at the
    stop, residuals of 1000 σ).  A monotone approach to the stop crosses a threshold at the
    same sample, filtered or not."""
    x = np.asarray(x, dtype=float)
    return median_filter(x, size=DESPIKE, mode="nearest") if x.size >= DESPIKE else x


def timed_switch(record: SeriesRecord, rig: Rig) -> float | None:
    """When the record's working phase was switched by time, its duration [s], else ``None``.

    Switched by time: a slow stroke (the last ``x`` farther than :data:`TIMED_MARGIN` of
    the stroke from its end) or a dwell at the stop (:func:`record_kind`); needs the ``x``
    channel and both phases.
    """
    if record_kind(record, rig) == "full":
        return None
    assert record.phase is not None
    work = np.flatnonzero(record.phase == "working")
    ret = np.flatnonzero(record.phase == "return")
    return float(record.t[ret[0]] - record.t[work[0]])


def simulate_record(rig: Rig, record: SeriesRecord,
                    overrides: Mapping[str, float] | None = None) -> pd.DataFrame:
    """The rig run like ``record`` was: its condition, its phase switch (module docstring).

    Raises
    ------
    SimulationError
        If the solver fails.
    """
    return simulate(rig, condition_of(record, rig), overrides, timed_switch(record, rig))


def solver_error(tables: list[pd.DataFrame]) -> dict[str, float]:
    """Largest estimated solver error per output over ``tables`` [σ of its sensor]."""
    worst: dict[str, float] = {}
    for table in tables:
        for name, value in dict(table.attrs.get("solver", {})).items():
            worst[name] = max(worst.get(name, 0.0), float(value))
    return worst


def phase_segments(table: pd.DataFrame, phase: str, stroke: float) -> list[pd.DataFrame]:
    """A phase of a simulated table cut where its piston reaches its stop: the motion, and
    the dwell at the stop when it lasts longer than :data:`DWELL_MIN` (each with its own
    time origin, ``t [s]`` from its start: :func:`model_phase_start`, :func:`phase_start`).

    ``stroke`` [m] is the cylinder's stroke; the working phase ends at ``x = stroke``, the
    return phase at ``x = 0``.  Without an ``x [m]`` column the phase is one segment.
    """
    tab = table[table["phase"] == phase]
    t = tab["t [s]"].to_numpy(dtype=float)
    x = tab["x [m]"].to_numpy(dtype=float) if "x [m]" in tab else None
    cut = t.size
    if x is not None and t.size:
        end = stroke if phase == "working" else 0.0
        at = np.flatnonzero(np.abs(x - end) <= AT_STOP)
        cut = int(at[0]) if at.size else t.size
    parts = [(tab.iloc[:cut], model_phase_start(table, phase))]
    if cut < t.size and t[-1] - t[cut] > DWELL_MIN:
        parts.append((tab.iloc[cut:], phase_start(t, cut)))  # the arrival at the stop
    return [p.assign(**{"t [s]": p["t [s]"].to_numpy(dtype=float) - origin})
            for p, origin in parts if len(p) > 2]


def on_grid(table: pd.DataFrame, t: Arr, channels: list[str]) -> dict[str, Arr]:
    """Channels of a simulated table linearly interpolated at the times ``t`` [s].

    ``channels`` are bare names (``"P1"``); the table's columns carry units
    (``"P1 [Pa]"``).  Times beyond the table hold its last value.
    """
    ts = table["t [s]"].to_numpy(dtype=float)
    by_name = {c.split(" [")[0]: c for c in table.columns}
    return {c: np.interp(t, ts, table[by_name[c]].to_numpy(dtype=float)) for c in channels}


def model_origin(record: SeriesRecord, table: pd.DataFrame, phase: str) -> float:
    """Where in its phase ``phase`` the simulated ``table`` is read at the record's phase
    start [s]: 0, except for the return of a record whose phases were read off the
    position (:func:`diagnostics.cycle_readings.phases_from_position`), which starts at
    the piston's reversal, a few ms after the valve switched — the model's return is then
    read from its own reversal on (:func:`~diagnostics.cycle_readings.reversal_delay`,
    the model's travel as the stroke).  Compared from the valve's switch, a seal friction
    hidden in such records was re-fitted 8 % low, and a stated-load error that acts only
    in the working stroke fitted them better than the truth."""
    if phase != "return" or record.metadata.get(PHASE_SOURCE) != "position":
        return 0.0
    x = table["x [m]"].to_numpy(dtype=float)
    t = table["t [s]"].to_numpy(dtype=float)
    labels = table["phase"].to_numpy(dtype=str)
    delay = reversal_delay(t, x, labels, float(np.ptp(x)))
    first = np.flatnonzero(labels == "return")
    if first.size == 0:
        return 0.0
    # the row the reversal was read at, placed as the record's own is (:func:`phase_start`)
    read = min(int(np.searchsorted(t, t[first[0]] + delay - 1e-12)), t.size - 1)
    return phase_start(t, read) - model_phase_start(table, "return")


#: a solver error over this many σ of the records' noise is not "well below" it [σ]
SOLVER_WELL_BELOW = 0.3


def solver_statement(tables: list[pd.DataFrame], noise: Mapping[str, Noise]) -> str:
    """How the workflow simulated, and the largest solver error it reached, in σ of the
    noise read from the records (the σ every gap is judged in).

    The solver states its error in σ of its default instruments
    (:data:`sim.solver.noise.DEFAULT_NOISE`: 25 kPa, 2.33e-6 m³/s, …); said as "of the
    sensors' noise" it read 3.8× small on records with 5 kPa of pressure noise and 18×
    small on quieter ones (a numerics pass).  Each is converted to the records' σ here, and
    an error not well below it (over :data:`SOLVER_WELL_BELOW` σ) is said as such.
    """
    worst = solver_error(tables)
    if not worst:
        return SOLVER
    units = {c.split(" [")[0]: c.split(" [")[1].rstrip("]")
             for t in tables for c in t.columns if " [" in c}
    shown: list[str] = []
    loud: list[str] = []
    for name, value in sorted(worst.items()):
        default = DEFAULT_NOISE.get(units.get(name, ""))
        read = noise[name].sigma if name in noise else None
        if default is None or read is None or not read > 0:
            continue
        in_read = value * default / read
        shown.append(f"{name} {in_read:.2g} σ")
        if in_read > SOLVER_WELL_BELOW:
            loud.append(name)
    if not shown:
        return SOLVER
    text = (f"{SOLVER}; estimated solver error at most {', '.join(shown)} of the noise read "
            "from the records")
    if loud:
        text += (f" — not well below it on {', '.join(loud)}: these records are quieter than "
                 "the solver's default instruments, and a gap there of a fraction of σ may be "
                 "the solver's")
    return text
