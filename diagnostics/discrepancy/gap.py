"""Gap between model and measurement, per output and region, and whiteness of residuals.

Model and measurement are compared phase by phase on the time since the phase start (the
record's midway between its first sample and the one before, the model's at its switch
event: :func:`~diagnostics.discrepancy.simulate.phase_start`; a
different stroke time must not count as a huge error at the phase switch; a return whose
phases were read off the position from the model's own reversal,
:func:`~diagnostics.discrepancy.simulate.model_origin`), over the shorter of the two phase
durations, in two regions: ``after step`` (the first 10 % of the
phase, after the valve switched) and ``steady`` (10-90 %).  Whiteness is the Ljung-Box
test (statsmodels ``acorr_ljungbox``) on the residual sampled every 20 ms.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd
from statsmodels.stats.diagnostic import acorr_ljungbox

from diagnostics.discrepancy.signals import noise_sigma
from diagnostics.discrepancy.simulate import (
    model_origin,
    model_phase_start,
    on_grid,
    phase_start,
)
from diagnostics.timeseries import SeriesRecord

__all__ = ["GapRow", "aligned_residuals", "gap_table", "ljung_box_p", "noise_sigma"]

Arr = npt.NDArray[np.float64]

REGIONS = ("after step", "steady")


@dataclass
class GapRow:
    """RMSE and max |error| of one channel in one region [SI unit of the channel]."""

    channel: str
    unit: str
    region: str
    rmse: float
    max_abs: float
    #: RMSE the model alone shows when its switch moves by half a sample period, the
    #: uncertainty with which a logged switch is placed (:func:`gap_table`) [SI unit]
    timing_floor: float = 0.0


def aligned_residuals(record: SeriesRecord, table: pd.DataFrame, channels: Sequence[str],
                      shift: float = 0.0) -> dict[str, dict[str, tuple[Arr, Arr, Arr]]]:
    """Residual model − measurement by phase: channel → phase → (t since start, residual, measured).

    Only the part of each phase both cover; ``t`` [s]; ``shift`` [s] reads the model that
    much later in its phase.
    """
    out: dict[str, dict[str, tuple[Arr, Arr, Arr]]] = {c: {} for c in channels}
    phases = record.phase if record.phase is not None else np.full(record.t.size, "working")
    for ph in ("working", "return"):
        sel = phases == ph
        tab = table[table["phase"] == ph]
        if sel.sum() < 3 or len(tab) < 3:
            continue
        tm = record.t[sel] - phase_start(record.t, int(np.flatnonzero(sel)[0]))
        ts = tab["t [s]"].to_numpy(dtype=float) - model_phase_start(table, ph)
        tab = tab.assign(**{"t [s]": ts})
        origin = model_origin(record, table, ph)
        keep = tm + origin <= ts[-1]
        model = on_grid(tab, tm[keep] + origin + shift, list(channels))
        for c in channels:
            meas = record.channels[c][sel][keep]
            out[c][ph] = (tm[keep], model[c] - meas, meas)
    return out


def gap_table(record: SeriesRecord, table: pd.DataFrame, channels: Sequence[str]) -> list[GapRow]:
    """RMSE and max error per channel and region (module docstring), each with its timing
    floor: the RMSE between the model and itself read half a sample period later.  A
    logged switch is placed to within a sample, and after a switch the pressures ring at
    hundreds of hertz, so on a cycle logged at 500 Hz the model's own data showed gaps
    of 11-29 bar "after step" (a user pass): the floor says how much of such a gap the
    logging alone explains."""
    res = aligned_residuals(record, table, channels)
    dt = np.diff(record.t)
    half = 0.5 * float(np.median(dt)) if dt.size else 0.0
    shifted = aligned_residuals(record, table, channels, shift=half)
    rows: list[GapRow] = []
    for c in channels:
        parts: dict[str, list[Arr]] = {r: [] for r in REGIONS}
        floors: dict[str, list[Arr]] = {r: [] for r in REGIONS}
        for ph, (t, r, _) in res[c].items():
            if t.size == 0:
                continue
            moved = shifted[c][ph][1] - r
            edge = 0.1 * t[-1]
            early, steady = t < edge, (t >= edge) & (t <= 0.9 * t[-1])
            parts["after step"].append(r[early])
            parts["steady"].append(r[steady])
            floors["after step"].append(moved[early])
            floors["steady"].append(moved[steady])
        for region, arrs in parts.items():
            e = np.concatenate(arrs) if arrs else np.zeros(0)
            if e.size == 0:
                continue
            f = np.concatenate(floors[region])
            rows.append(GapRow(c, record.units[c], region, float(np.sqrt(np.mean(e * e))),
                               float(np.max(np.abs(e))), float(np.sqrt(np.mean(f * f)))))
    return rows


def ljung_box_p(residual: Arr, *, rate: float, every: float = 0.02, lags: int = 10) -> float:
    """Ljung-Box p-value of ``residual`` sampled every ``every`` seconds (white: p large)."""
    step = max(1, round(every * rate))
    r = np.asarray(residual, dtype=float)[::step]
    if r.size < lags + 5 or float(np.std(r)) == 0.0:
        return float("nan")
    res = acorr_ljungbox(r - r.mean(), lags=[lags])
    return float(res["lb_pvalue"].iloc[0])
