"""Measured records on a uniform grid, with Savitzky-Golay derivatives and conditions.

Equation-error residuals need time derivatives of measured pressures and speed; raw
finite differences of noisy data make noise look like physics (DISCREPANCY.md: 77-100 %
false discoveries), so every derivative here is a Savitzky-Golay derivative (Savitzky &
Golay, *Anal. Chem.* 36, 1964) taken per record and phase on a uniform grid.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.signal import savgol_filter

from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError
from sim.rigs.assembly import Condition, Rig

__all__ = ["DERIVED", "Signals", "condition_of", "prepare", "stated_coefficients"]

Arr = npt.NDArray[np.float64]

#: channels whose Savitzky-Golay derivative the balances use
DERIVED = ("v", "P1", "P2", "P_pump")


@dataclass
class Signals:
    """Stacked samples of all records, SI.

    Attributes
    ----------
    values
        Channel → samples (measured channels, ``d<channel>`` derivatives, ``mu`` [Pa·s],
        ``load`` [N] per sample (0 in the return phase), ``T`` [°C], the stated rig's
        constants of :func:`stated_coefficients`).
    record
        Record index of each sample.
    phase
        Phase label per sample (``working``/``return``/``""``).
    t
        Time of each sample within its record [s].
    names
        Record names.
    """

    values: dict[str, Arr]
    record: npt.NDArray[np.int64]
    phase: npt.NDArray[np.str_]
    t: Arr
    names: list[str]

    def has(self, *channels: str) -> bool:
        """Whether every channel is present."""
        return all(c in self.values for c in channels)

    def since_phase_start(self) -> Arr:
        """Time since the start of each sample's phase within its record [s]."""
        out = np.zeros(self.t.size)
        for rec in np.unique(self.record):
            for ph in np.unique(self.phase):
                m = (self.record == rec) & (self.phase == ph)
                if m.any():
                    out[m] = self.t[m] - self.t[m].min()
        return out

    def subset(self, mask: npt.NDArray[np.bool_]) -> Signals:
        """The samples where ``mask`` holds."""
        return Signals({k: v[mask] for k, v in self.values.items()}, self.record[mask],
                       self.phase[mask], self.t[mask], self.names)


def condition_of(record: SeriesRecord, rig: Rig) -> Condition:
    """The operating condition of a record (its constant condition channels, else the rig's)."""
    base = rig.default_condition()
    c = record.condition
    return Condition(load=c.get("load", base.load),
                     back_pressure=c.get("back_pressure", base.back_pressure),
                     oil_temperature=c.get("oil_temperature", base.oil_temperature),
                     pump_speed=c.get("pump_speed"))


def stated_coefficients(values: Mapping[str, float]) -> dict[str, float]:
    """Constants of the stated rig that library regressors scale by, SI.

    ``G_piston`` [m³]: the piston gap's laminar coefficient π·D·c³/(12·L) of paper 002
    eq. 36 (leak = G·(P1 − P2)/μ); ``V02`` [m³], ``A2`` [m²], ``stroke`` [m]: chamber 2's
    dead volume, annulus and stroke (eq. 34); ``Pset`` [Pa], ``Rrv`` [Pa·s/m³]: the relief
    valve's setting and slope (eq. 6); ``Rlp`` [Pa·s/m³], ``Cp`` [m³/Pa]: the pump's
    leakage resistance and outlet capacitance (eqs. 1-5), with which a regressor estimates
    the relief flow from measured signals; ``I_hose_B`` [kg/m⁴]: hose B's oil-column
    inertance.  Each is present when the rig has the component.
    """
    out: dict[str, float] = {}
    if all(k in values for k in ("cylinder.bore", "cylinder.cc", "cylinder.Lc")):
        out["G_piston"] = (math.pi * values["cylinder.bore"] * values["cylinder.cc"] ** 3
                           / (12.0 * values["cylinder.Lc"]))
    for key in ("cylinder.V02", "cylinder.A2", "cylinder.stroke", "relief.Pset", "relief.Rrv",
                "pump.Rlp", "pump.Cp"):
        if key in values:
            out[key.partition(".")[2]] = values[key]
    if "hose_B.I" in values:
        out["I_hose_B"] = values["hose_B.I"]
    return out


def _uniform(record: SeriesRecord, rate: float) -> tuple[Arr, dict[str, Arr], npt.NDArray[np.str_]]:
    t0, t1 = float(record.t[0]), float(record.t[-1])
    n = int(np.floor((t1 - t0) * rate)) + 1
    t = t0 + np.arange(n) / rate
    chans = {k: np.interp(t, record.t, v) for k, v in record.channels.items()}
    if record.phase is None:
        phase = np.full(n, "", dtype=object)
    else:
        idx = np.clip(np.searchsorted(record.t, t, side="right") - 1, 0, record.t.size - 1)
        phase = np.asarray(record.phase, dtype=object)[idx]
    return t, chans, np.asarray(phase, dtype=str)


def prepare(records: Sequence[SeriesRecord], rig: Rig, *, rate: float = 1000.0,
            window: float = 0.041) -> Signals:
    """Resample ``records`` to ``rate`` [Hz], smooth, add derivatives and conditions.

    Every channel is smoothed with the same cubic Savitzky-Golay window as the
    derivatives, per record and phase.

    Parameters
    ----------
    records
        Measured records (any subset of the rig's output channels).
    rig
        The rig (for the fluid's viscosity at each record's temperature).
    rate
        Uniform sampling rate [Hz] of the analysis.
    window
        Savitzky-Golay window [s] (cubic).

    Raises
    ------
    InputError
        No records, or records whose channels differ (``field="file"``).
    """
    if not records:
        raise InputError("no records to analyse", field="file")
    common = set(records[0].channels)
    for r in records[1:]:
        if set(r.channels) != common:
            raise InputError(f"record {r.name!r} has channels {sorted(r.channels)}, the first "
                             f"has {sorted(common)}", field="file")
    parts: dict[str, list[Arr]] = {}
    rec_idx: list[npt.NDArray[np.int64]] = []
    phases: list[npt.NDArray[np.str_]] = []
    times: list[Arr] = []
    w = max(5, round(window * rate) | 1)
    for i, r in enumerate(records):
        t, ch, phase = _uniform(r, rate)
        cond = condition_of(r, rig)
        derivs = {f"d{c}": np.zeros_like(t) for c in DERIVED if c in ch}
        smooth = {c: v.copy() for c, v in ch.items()}
        for ph in np.unique(phase):
            sel = phase == ph
            if sel.sum() < w + 2:
                continue
            for c in ch:
                # the same filter on every signal of a balance: a derivative taken through
                # the window must not meet an unfiltered signal
                smooth[c][sel] = savgol_filter(ch[c][sel], w, 3, deriv=0)
                if c in DERIVED:
                    derivs[f"d{c}"][sel] = savgol_filter(ch[c][sel], w, 3, deriv=1,
                                                         delta=1.0 / rate)
        ch = smooth
        ch.update(derivs)
        values = rig.values(condition=cond)
        # the rig's μ at this temperature, with any fluid correction it carries (a fitted
        # viscosity law of an augmented rig)
        ch["mu"] = np.full(t.size, values["fluid.mu"])
        ch["T"] = np.full(t.size, cond.oil_temperature)
        ch["load"] = np.where(phase == "return", 0.0, cond.load)
        speed = cond.pump_speed if cond.pump_speed is not None else rig.base["pump.speed"]
        ch["speed"] = np.full(t.size, speed)
        ch["Vp"] = np.full(t.size, rig.base["pump.Vp"])
        for k, const in stated_coefficients(values).items():
            ch[k] = np.full(t.size, const)
        for k, v in ch.items():
            parts.setdefault(k, []).append(v)
        rec_idx.append(np.full(t.size, i, dtype=np.int64))
        phases.append(phase)
        times.append(t - t[0])
    return Signals({k: np.concatenate(v) for k, v in parts.items()}, np.concatenate(rec_idx),
                   np.concatenate(phases), np.concatenate(times), [r.name for r in records])
