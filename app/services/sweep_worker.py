"""What a sweep worker runs: a chunk of scenarios of one rig, in any process.

This module imports nothing of the service (no web framework, no store), so that a
process pool or a Dask worker loads only :mod:`sim`.  A worker keeps the compiled rigs it
has seen (keyed by the document's digest), so the steady path's continuation from the
last operating point carries over from one chunk to the next.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from sim.cycle import PHASES, SUMMARY_UNITS, run_cycle
from sim.errors import HydrodiagError
from sim.rigs import Condition
from sim.rigs.process_cache import rig_of_document
from sim.steady import steady_cycle

__all__ = ["SUMMARY_COLUMNS", "evaluate_chunk"]

#: Summary columns of every sweep result, in order.
SUMMARY_COLUMNS: tuple[str, ...] = (
    *(f"{phase}.{key} [{unit}]" for phase in PHASES for key, unit in SUMMARY_UNITS.items()),
    "velocity_ratio [-]",
)


def _values(summary: Mapping[str, float]) -> list[float | None]:
    out: list[float | None] = []
    for column in SUMMARY_COLUMNS:
        value = summary.get(column)
        out.append(float(value) if value is not None and math.isfinite(value) else None)
    return out


def evaluate_chunk(document: Mapping[str, Any], method: str,
                   points: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Run each scenario of ``points`` on the rig of ``document``.

    Parameters
    ----------
    document
        The rig document (validated by the caller).
    method
        ``"steady"`` (operating points) or ``"transient"`` (one cycle each).
    points
        Scenarios ``{"overrides": {role.name: SI}, "condition": {load [N], back_pressure
        [Pa], oil_temperature [°C], pump_speed [rad/s] or None}}``.

    Returns
    -------
    list of dict
        Per point ``{"values": [...]}`` in :data:`SUMMARY_COLUMNS` order, or
        ``{"error": message}`` when the point has no solution (a stall, a failed solve):
        one bad point does not end a sweep.
    """
    rig = rig_of_document(document)
    out: list[dict[str, Any]] = []
    for point in points:
        condition = Condition(**point["condition"])
        try:
            if method == "steady":
                result = steady_cycle(rig, point["overrides"], condition)
            else:
                result = run_cycle(rig, point["overrides"], condition, timeseries=False)
        except HydrodiagError as exc:
            out.append({"error": f"{type(exc).__name__}: {exc}"})
            continue
        out.append({"values": _values(result.summary())})
    return out
