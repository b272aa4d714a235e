"""Confirmation of a slow-speed effect by statistics that do not depend on the slip instants.

Stribeck friction leaves its signature only where the piston moves slowly, and there the
piston stick-slips: the instants of each slip depend on the noise-free state to a
fraction of a millisecond, so a re-simulation cannot align model and measurement sample
by sample, however right the friction law.  An entry whose signature lies there
(``EffectEntry.window == "slow"``) is confirmed on the timed slow-motion strokes
(:func:`~diagnostics.discrepancy.simulate.timed_switch`) by statistics of each phase's
steady part (10-90 %), per logged channel: the mean and the spread (standard deviation;
the model's combined with the sensor's noise σ).  Their standard errors come from the
measurement itself: the window is cut into :data:`BLOCKS` blocks and the spread of the
block statistics gives the error (Künsch-style batch means), so no model of the
slip times enters.  The coefficient is re-fitted by a bounded 1-D search on the χ² of
these statistics, and the held-out slow stroke must show the χ² excess over its degrees
of freedom shrinking by at least the workflow's confirmation ratio.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import stats
from scipy.optimize import minimize_scalar

from diagnostics.discrepancy.refit import with_effects
from diagnostics.discrepancy.simulate import (
    model_phase_start,
    on_grid,
    phase_start,
    simulate_record,
    timed_switch,
)
from diagnostics.timeseries import SeriesRecord
from sim.components.effects import EFFECTS, parameter_bounds
from sim.errors import InputError, SimulationError
from sim.rigs.assembly import Rig
from sim.rigs.schema import validate_rig_document

__all__ = ["BLOCKS", "is_slow", "slow_chi2", "slow_records", "slow_refit"]

Arr = npt.NDArray[np.float64]

#: blocks per phase window whose spread gives the statistics' standard errors
BLOCKS = 8
#: range of the 1-D search around the equation-error start [factor either side]
SEARCH = 10.0


def is_slow(keys: Sequence[str]) -> bool:
    """Whether every effect of the parameters ``keys`` (``effect.param``) declares a
    slow-speed signature (module docstring)."""
    return bool(keys) and all(EFFECTS[k.partition(".")[0]].entry.window == "slow"
                              for k in keys)


def slow_records(records: Sequence[SeriesRecord], rig: Rig) -> list[SeriesRecord]:
    """The timed slow-motion strokes among ``records``."""
    return [r for r in records if timed_switch(r, rig) is not None]


def _blocks(x: Arr) -> tuple[Arr, Arr]:
    parts = np.array_split(x, BLOCKS)
    return (np.array([float(np.mean(p)) for p in parts]),
            np.array([float(np.std(p)) for p in parts]))


def slow_chi2(rig: Rig, records: Sequence[SeriesRecord], channels: Sequence[str],
              sig: Mapping[str, float], overrides: Mapping[str, float] | None = None
              ) -> tuple[float, int]:
    """χ² of the model's phase statistics against the records' and its degrees of freedom.

    For each record, phase and channel: the window's mean and spread, model − measured,
    over the measured block standard error (module docstring).  ``sig`` [SI] is each
    channel's sensor noise σ.

    Raises
    ------
    SimulationError
        If the solver fails.
    """
    chi2, dof = 0.0, 0
    for r in records:
        table = simulate_record(rig, r, overrides)
        phases = r.phase if r.phase is not None else np.full(r.t.size, "working")
        for ph in ("working", "return"):
            sel = np.flatnonzero(phases == ph)
            tab = table[table["phase"] == ph]
            if sel.size < 20 * BLOCKS or len(tab) < 3:
                continue
            tm = r.t[sel] - phase_start(r.t, int(sel[0]))
            keep = (tm >= 0.1 * tm[-1]) & (tm <= 0.9 * tm[-1])
            ts = tab["t [s]"].to_numpy(dtype=float) - model_phase_start(table, ph)
            model = on_grid(tab.assign(**{"t [s]": ts}), tm[keep], list(channels))
            for c in channels:
                m_mean, m_std = _blocks(r.channels[c][sel][keep])
                s_mean, s_std = _blocks(model[c])
                floor = 0.05 * sig[c]
                se_mean = math.hypot(float(np.std(m_mean, ddof=1)) / math.sqrt(BLOCKS), floor)
                se_std = math.hypot(float(np.std(m_std, ddof=1)) / math.sqrt(BLOCKS), floor)
                spread_model = float(np.mean(np.sqrt(s_std ** 2 + sig[c] ** 2)))
                chi2 += ((float(np.mean(s_mean)) - float(np.mean(m_mean))) / se_mean) ** 2
                chi2 += ((spread_model - float(np.mean(m_std))) / se_std) ** 2
                dof += 2
    return chi2, dof


def slow_refit(doc: dict[str, Any], start: Mapping[str, float], records: Sequence[SeriesRecord],
               channels: Sequence[str], sig: Mapping[str, float]
               ) -> tuple[dict[str, float], dict[str, float]]:
    """Re-fit one slow-speed coefficient on the statistics of the timed slow strokes.

    A bounded search of χ² (:func:`slow_chi2`) over log(coefficient) within
    :data:`SEARCH` × of the equation-error ``start`` and the parameter's bounds; the 1-σ
    error from the χ² curvature (Δχ² = 1).  Returns (values, errors) as
    :func:`~diagnostics.discrepancy.refit.refit`; a start of several coefficients is
    returned unchanged with ``nan`` errors.
    """
    keys = list(start)
    if len(keys) != 1 or not records:
        return dict(start), dict.fromkeys(keys, float("nan"))
    key = keys[0]
    rig = Rig.from_spec(validate_rig_document(with_effects(doc, start)))
    lo, hi = parameter_bounds(keys)
    x0 = abs(start[key]) or 1.0
    a = math.log(max(x0 / SEARCH, float(lo[0]), 1e-300))
    b = math.log(min(x0 * SEARCH, float(hi[0])))

    def cost(log_x: float) -> float:
        try:
            return slow_chi2(rig, records, channels, sig, {key: math.exp(log_x)})[0]
        except (SimulationError, InputError):
            return math.inf

    best = minimize_scalar(cost, bounds=(a, b), method="bounded", options={"xatol": 0.02})
    value = math.exp(float(best.x))
    h = 0.2  # 20 %: the statistics vary unevenly with the coefficient on a finer scale
    c0, cp, cm = float(best.fun), cost(best.x + h), cost(best.x - h)
    curv = (cp - 2 * c0 + cm) / (h * h)  # d²χ²/d(log x)²
    # Δχ² = 1, inflated by χ²/dof when the statistics are matched worse than their
    # errors say (as the output-error re-fit scales by the residual variance)
    dof = max(slow_chi2(rig, records, channels, sig, {key: value})[1] - 1, 1)
    inflate = math.sqrt(max(c0 / dof, 1.0))
    err = (value * math.sqrt(2.0 / curv) * inflate if curv > 0 and math.isfinite(curv)
           else float("nan"))
    return {key: value}, {key: err}


def slow_confirmed(base: Rig, trial: Rig, held: Sequence[SeriesRecord],
                   channels: Sequence[str], sig: Mapping[str, float], ratio: float) -> bool:
    """Whether the held-out slow strokes' statistics confirm the trial rig: the base's χ²
    exceeds its 99 % point and the χ² excess over the degrees of freedom shrinks by at
    least ``ratio`` in root (the workflow's excess-gap ratio, here on statistics)."""
    if not held:
        return False
    try:
        before, dof = slow_chi2(base, held, channels, sig)
        after, _ = slow_chi2(trial, held, channels, sig)
    except (SimulationError, InputError):
        return False
    if dof == 0 or before <= stats.chi2.ppf(0.99, dof):
        return False
    excess_after = max(after - dof, 0.0)
    return excess_after == 0.0 or math.sqrt((before - dof) / excess_after) >= ratio
