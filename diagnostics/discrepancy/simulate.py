"""The one call of the transient rig model used by the discrepancy workflow.

Every simulation of the workflow (residuals, output-error re-fits, held-out checks, the
hidden-effect bench) goes through :func:`simulate`, so that swapping the solver is one
line.  Today it is :func:`sim.cycle.run_cycle` with ``rtol = 1e-5`` (the ROS2 solver; its
error on the piston speed is about 0.35 σ of the bench's sensor noise).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt
import pandas as pd

from sim.cycle import run_cycle
from sim.rigs.assembly import Condition, Rig

__all__ = ["SOLVER_RTOL", "on_grid", "simulate"]

Arr = npt.NDArray[np.float64]

#: relative tolerance of the transient solver for every workflow simulation
SOLVER_RTOL = 1e-5


def simulate(rig: Rig, condition: Condition | None = None,
             overrides: Mapping[str, float] | None = None) -> pd.DataFrame:
    """One working + return cycle as a time-series table (the ``/simulate`` export format).

    Raises
    ------
    SimulationError
        If the solver fails.
    """
    res = run_cycle(rig, overrides, condition, rtol=SOLVER_RTOL, timeseries=True)
    assert res.timeseries is not None
    return res.timeseries


def on_grid(table: pd.DataFrame, t: Arr, channels: list[str]) -> dict[str, Arr]:
    """Channels of a simulated table linearly interpolated at the times ``t`` [s].

    ``channels`` are bare names (``"P1"``); the table's columns carry units
    (``"P1 [Pa]"``).  Times beyond the table hold its last value.
    """
    ts = table["t [s]"].to_numpy(dtype=float)
    by_name = {c.split(" [")[0]: c for c in table.columns}
    return {c: np.interp(t, ts, table[by_name[c]].to_numpy(dtype=float)) for c in channels}
