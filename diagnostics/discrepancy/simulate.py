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
same time.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt
import pandas as pd

from diagnostics.discrepancy.signals import condition_of
from diagnostics.timeseries import SeriesRecord
from sim.cycle import run_cycle
from sim.rigs.assembly import Condition, Rig

__all__ = ["SAMPLE_RATE", "SOLVER", "TIMED_MARGIN", "on_grid", "simulate", "simulate_record",
           "solver_error", "timed_switch"]

Arr = npt.NDArray[np.float64]

#: output grid of every workflow simulation, from the solver's dense output [Hz]
SAMPLE_RATE = 5000.0
#: how the workflow simulates, in words (for the report)
SOLVER = (f"sim.cycle.run_cycle, RODAS4, noise-accurate (≤ 0.3 σ velocity, ≤ 0.1 σ pressure "
          f"and flow), dense output at {SAMPLE_RATE:g} Hz")
#: a working phase ending farther than this fraction of the stroke from the stroke end was
#: switched by time, not by the end stop [-]
TIMED_MARGIN = 0.05


def simulate(rig: Rig, condition: Condition | None = None,
             overrides: Mapping[str, float] | None = None,
             t_max: float | None = None) -> pd.DataFrame:
    """One working + return cycle as a time-series table (the ``/simulate`` export format).

    ``t_max`` [s] switches each phase after that long at the latest (a timed stroke);
    ``None``: the end stops switch (:func:`sim.cycle.run_cycle`).

    Raises
    ------
    SimulationError
        If the solver fails.
    """
    res = run_cycle(rig, overrides, condition, method="rodas4", sample_rate=SAMPLE_RATE,
                    timeseries=True, t_max=t_max)
    assert res.timeseries is not None
    table = res.timeseries
    table.attrs["solver"] = dict(res.solver.error_sigma or {}) if res.solver else {}
    return table


def timed_switch(record: SeriesRecord, rig: Rig) -> float | None:
    """When the record's working phase was switched by time, its duration [s], else ``None``.

    Needs the ``x`` channel and both phases; a working phase whose last ``x`` lies within
    :data:`TIMED_MARGIN` of the stroke end was switched by the end stop (``None``).
    """
    if record.phase is None or "x" not in record.channels:
        return None
    work = np.flatnonzero(record.phase == "working")
    ret = np.flatnonzero(record.phase == "return")
    if work.size < 2 or ret.size == 0:
        return None
    stroke = rig.base["cylinder.stroke"]
    if record.channels["x"][work[-1]] >= (1.0 - TIMED_MARGIN) * stroke:
        return None
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


def on_grid(table: pd.DataFrame, t: Arr, channels: list[str]) -> dict[str, Arr]:
    """Channels of a simulated table linearly interpolated at the times ``t`` [s].

    ``channels`` are bare names (``"P1"``); the table's columns carry units
    (``"P1 [Pa]"``).  Times beyond the table hold its last value.
    """
    ts = table["t [s]"].to_numpy(dtype=float)
    by_name = {c.split(" [")[0]: c for c in table.columns}
    return {c: np.interp(t, ts, table[by_name[c]].to_numpy(dtype=float)) for c in channels}
