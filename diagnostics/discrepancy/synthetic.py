"""Synthetic measurements: a rig's simulated cycle sampled like a data logger, with noise.

Used by the hidden-effect bench and the tests: the data come from a rig *with* an effect,
the workflow starts from the rig *without* it.  Noise kinds: ``gaussian`` (σ per
channel), ``proportional`` (σ × |reading| / full scale + a floor of σ/4) and
``heavy`` (Student t with 3 degrees of freedom scaled to the same σ).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

from diagnostics.discrepancy.simulate import on_grid, simulate
from diagnostics.timeseries import SeriesRecord
from sim.rigs.assembly import Condition, Rig

__all__ = ["CHANNELS", "NOISE", "UNITS", "synthesize"]

Arr = npt.NDArray[np.float64]

#: channels a rig logger records, with their SI unit
UNITS: dict[str, str] = {"x": "m", "v": "m/s", "P1": "Pa", "P2": "Pa", "P_pump": "Pa",
                         "P_valve_P": "Pa", "Q_meter_B": "m^3/s", "Q_meter_C": "m^3/s"}
CHANNELS = tuple(UNITS)

#: default sensor noise σ per channel [SI]: 0.05 bar, 1 mm/s, 0.1 mm, 0.05 L/min
NOISE: dict[str, float] = {"x": 1e-4, "v": 1e-3, "P1": 5e3, "P2": 5e3, "P_pump": 5e3,
                           "P_valve_P": 5e3, "Q_meter_B": 8.3e-7, "Q_meter_C": 8.3e-7}


def synthesize(rig: Rig, condition: Condition, *, rng: np.random.Generator,
               name: str = "record", rate: float = 1000.0, noise: str = "gaussian",
               sigma: Mapping[str, float] | None = None,
               overrides: Mapping[str, float] | None = None,
               channels: Sequence[str] = CHANNELS) -> SeriesRecord:
    """One simulated cycle sampled at ``rate`` [Hz] with sensor noise (module docstring)."""
    table = simulate(rig, condition, overrides)
    t_end = float(table["t [s]"].iloc[-1])
    t = np.arange(0.0, t_end, 1.0 / rate)
    clean = on_grid(table, t, list(channels))
    sig = dict(NOISE) | dict(sigma or {})
    chans: dict[str, Arr] = {}
    for c, v in clean.items():
        s = sig[c]
        if noise == "gaussian":
            e = rng.normal(0.0, s, v.size)
        elif noise == "proportional":
            fs = float(np.max(np.abs(v))) or 1.0
            e = rng.normal(0.0, 1.0, v.size) * (s * np.abs(v) / fs + s / 4)
        elif noise == "heavy":
            e = rng.standard_t(3, v.size) * s / np.sqrt(3.0)
        else:
            raise ValueError(f"unknown noise kind {noise!r}")
        chans[c] = v + e
    ts = table["t [s]"].to_numpy(dtype=float)
    idx = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, ts.size - 1)
    phase = table["phase"].to_numpy(dtype=str)[idx]
    cond = {"load": condition.load, "back_pressure": condition.back_pressure,
            "oil_temperature": condition.oil_temperature}
    return SeriesRecord(name, t, chans, {c: UNITS[c] for c in chans}, phase, cond,
                        measured=False)


def effect_peak(truth_table: object, base_table: object, *, rate: float = 1000.0,
                sigma: Mapping[str, float] | None = None,
                channels: Sequence[str] = CHANNELS) -> tuple[float, str]:
    """Largest |with − without| over channels in units of that channel's noise σ.

    Returns ``(peak / σ, channel)``: the effect's size as the bench states it.  Each phase
    is compared on the time since its start, over 10-90 % of the shorter of the two
    durations (steady motion), so that a start-up transient or a shifted end-stop arrival
    (a changed stroke time) does not count as a difference of many σ.
    """
    import pandas as pd

    assert isinstance(truth_table, pd.DataFrame) and isinstance(base_table, pd.DataFrame)
    sig = dict(NOISE) | dict(sigma or {})
    best, where = 0.0, ""
    for phase in ("working", "return"):
        a_tab = truth_table[truth_table["phase"] == phase]
        b_tab = base_table[base_table["phase"] == phase]
        ta = a_tab["t [s]"].to_numpy(dtype=float)
        tb = b_tab["t [s]"].to_numpy(dtype=float)
        span = min(ta[-1] - ta[0], tb[-1] - tb[0])
        t = np.arange(0.1 * span, 0.9 * span, 1.0 / rate)
        a_rel = a_tab.assign(**{"t [s]": ta - ta[0]})
        b_rel = b_tab.assign(**{"t [s]": tb - tb[0]})
        a = on_grid(a_rel, t, list(channels))
        b = on_grid(b_rel, t, list(channels))
        for c in channels:
            if c == "x":
                continue
            peak = float(np.max(np.abs(a[c] - b[c]))) / sig[c]
            if peak > best:
                best, where = peak, c
    return best, where
