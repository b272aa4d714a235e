"""Measured records on a uniform grid, with Savitzky-Golay derivatives and conditions.

Equation-error residuals need time derivatives of measured pressures and speed; raw
finite differences of noisy data make noise look like physics (DISCREPANCY.md: 77-100 %
false discoveries), so every derivative here is a Savitzky-Golay derivative (Savitzky &
Golay, *Anal. Chem.* 36, 1964) taken per record and phase on a uniform grid.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.signal import savgol_filter

from diagnostics.sampling import gap_spans
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError
from sim.rigs.assembly import Condition, Rig

__all__ = ["DERIVED", "HOSE", "HOSE_WINDOW", "Signals", "condition_of",
           "hose_integrals", "noise_sigma", "prepare", "stated_coefficients"]

Arr = npt.NDArray[np.float64]

#: channels whose Savitzky-Golay derivative the balances use
DERIVED = ("v", "P1", "P2", "P_pump")
#: channels of hose B's effort balance: chamber-2 pressure, valve-port-B pressure, meter C
HOSE = ("P2", "P_valve_B", "Q_meter_C")
#: window of the hose balance's running integrals [s]
HOSE_WINDOW = 0.02


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
    rate
        Uniform sampling rate of the records [Hz] (:func:`prepare`'s).
    """

    values: dict[str, Arr]
    record: npt.NDArray[np.int64]
    phase: npt.NDArray[np.str_]
    t: Arr
    names: list[str]
    rate: float = 1000.0

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
                       self.phase[mask], self.t[mask], self.names, self.rate)


def condition_of(record: SeriesRecord, rig: Rig) -> Condition:
    """The operating condition of a record: its constant condition channels; an oil
    temperature logged as a varying channel at its mean (the rig is simulated at one
    temperature); what the record does not state, the rig's (the workflow first checks
    that load and temperature are stated, :func:`~diagnostics.discrepancy.records.
    require_cycle_records`)."""
    base = rig.default_condition()
    c = record.condition
    temperature = c.get("oil_temperature")
    if temperature is None and "oil_temperature" in record.channels:
        temperature = float(np.mean(record.channels["oil_temperature"]))
    return Condition(load=c.get("load", base.load),
                     back_pressure=c.get("back_pressure", base.back_pressure),
                     oil_temperature=base.oil_temperature if temperature is None
                     else temperature,
                     pump_speed=c.get("pump_speed"))


def stated_coefficients(values: Mapping[str, float]) -> dict[str, float]:
    """Constants of the stated rig that library regressors scale by, SI.

    ``G_piston`` [m³]: the piston gap's laminar coefficient π·D·c³/(12·L) of paper 002
    eq. 36 (leak = G·(P1 − P2)/μ); ``V02`` [m³], ``A2`` [m²], ``stroke`` [m]: chamber 2's
    dead volume, annulus and stroke (eq. 34); ``Pset`` [Pa], ``Rrv`` [Pa·s/m³]: the relief
    valve's setting and slope (eq. 6); ``PRvt`` [Pa]: the 4/2 valve's T-port pressure
    (eq. 24; the spool leaks across P_P − PRvt, eq. 23); ``Rlp`` [Pa·s/m³], ``Cp`` [m³/Pa]:
    the pump's leakage resistance and outlet capacitance (eqs. 1-5), with which a regressor
    estimates the relief flow from measured signals; ``I_hose_B`` [kg/m⁴]: hose B's
    oil-column inertance.  Each is present when the rig has the component.
    """
    out: dict[str, float] = {}
    if all(k in values for k in ("cylinder.bore", "cylinder.cc", "cylinder.Lc")):
        out["G_piston"] = (math.pi * values["cylinder.bore"] * values["cylinder.cc"] ** 3
                           / (12.0 * values["cylinder.Lc"]))
    for key in ("cylinder.V02", "cylinder.A2", "cylinder.stroke", "relief.Pset", "relief.Rrv",
                "valve.PRvt", "pump.Rlp", "pump.Cp"):
        if key in values:
            out[key.partition(".")[2]] = values[key]
    if "hose_B.I" in values:
        out["I_hose_B"] = values["hose_B.I"]
    return out


def noise_sigma(x: Arr) -> float:
    """Noise σ of a smooth signal plus white noise, from the MAD of second differences."""
    d2 = np.diff(np.asarray(x, dtype=float), 2)
    if d2.size == 0:
        return 0.0
    return float(np.median(np.abs(d2 - np.median(d2))) / 0.6745 / math.sqrt(6.0))


def hose_integrals(t: Arr, p2: Arr, p_b: Arr, q_c: Arr, window: float = HOSE_WINDOW
                   ) -> dict[str, Arr]:
    """Running integrals of hose B's effort balance over the last ``window`` [s].

    Hose B joins valve port B to chamber 2 (paper 002 Figure 1; :mod:`sim.components.hose`):
    ``P2 − P_B = R·Q_C + I·dQ_C/dt`` with ``Q_C`` the flow out of chamber 2 (meter C).  Integrated
    from ``t − window`` to ``t`` it needs no derivative of measured data::

        ∫(P2 − P_B) dt = R·∫Q_C dt + I·(Q_C(t) − Q_C(t − window))

    The pressures oscillate by tens of bar for ≈ 0.2 s after each valve switch and end-stop
    arrival (the hose's oil column against the compliances, partly faster than a 1 kHz
    logger resolves); the integrals are taken on the raw samples (trapezoid with the
    Euler-Maclaurin end correction −h²/12·Δf′), not on smoothed ones, which such a
    transient would not survive.  Returns ``hose.int_dp`` [Pa·s], ``hose.int_q`` [m³],
    ``hose.dq`` [m³/s], ``hose.ok`` (1 where a whole window lies in the record, else 0),
    ``hose.hf`` [Pa·s], a bound of the trapezoid error over the window, Σ|Δ²(P2 − P_B)|·h/12
    (large where the transient is not resolved: the balance leaves those windows out), and
    ``hose.sigma_dp`` [Pa], the white noise σ of P2 − P_B per sample (:func:`noise_sigma`,
    constant over the record).
    """
    # a uniform grid (prepare's): the window is a whole number of samples
    h = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    dp = p2 - p_b
    cum_dp = np.concatenate([[0.0], np.cumsum(0.5 * (dp[1:] + dp[:-1]) * np.diff(t))])
    cum_q = np.concatenate([[0.0], np.cumsum(0.5 * (q_c[1:] + q_c[:-1]) * np.diff(t))])
    n = round(window / h) if h > 0 else 0
    idx = np.arange(t.size)
    ok = idx >= n
    j = np.where(ok, idx - n, 0)
    # Euler-Maclaurin end correction of the trapezoid rule, −h²/12·(f'(t) − f'(t − window))
    f1 = np.gradient(dp, t) if t.size > 2 else np.zeros_like(dp)
    corr = -h * h / 12.0 * (f1 - f1[j])
    d2 = np.zeros_like(dp)
    d2[1:-1] = np.abs(dp[2:] - 2.0 * dp[1:-1] + dp[:-2])
    cum_d2 = np.cumsum(d2) * h / 12.0
    # the sensors' white noise in P2 − P_B (robust to the transients): what the windowed
    # integral carries even where the model is exact; per sample, as the balance keeps a
    # subset of the records' stacked samples
    return {"hose.int_dp": cum_dp - cum_dp[j] + corr, "hose.int_q": cum_q - cum_q[j],
            "hose.dq": q_c - q_c[j], "hose.ok": ok.astype(float), "hose.hf": cum_d2 - cum_d2[j],
            "hose.sigma_dp": np.full(t.size, noise_sigma(dp))}


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


def _measured(record: SeriesRecord, t: Arr, margin: float) -> npt.NDArray[np.bool_]:
    """Which samples of the uniform grid ``t`` [s] rest on measured samples: not inside a
    gap of the record (:func:`~diagnostics.sampling.gap_spans`) nor within ``margin`` [s]
    of one, where the smoothing window reaches the interpolation across it.  A 0.5 s
    dropout resampled straight across made "structure" in the chamber-flow balance and
    healthy records read "unexplained" (a discrepancy pass)."""
    out = np.ones(t.size, dtype=bool)
    for a, b in gap_spans(record):
        out &= ~((t > a - margin) & (t < b + margin))
    return out


def same_channels(records: Sequence[SeriesRecord], only: Collection[str] | None = None
                  ) -> None:
    """Refuse records whose channels (of ``only``, when given) differ (``field="file"``):
    the workflow compares every record on the same outputs."""
    def chosen(r: SeriesRecord) -> set[str]:
        return {c for c in r.channels if only is None or c in only}

    common = chosen(records[0])
    for r in records[1:]:
        if chosen(r) != common:
            missing, extra = sorted(common - chosen(r)), sorted(chosen(r) - common)
            raise InputError(
                f"record {r.name!r} has channels {sorted(chosen(r))}, the first "
                f"({records[0].name!r}) has {sorted(common)}"
                + (f"; it lacks {', '.join(missing)}" if missing else "")
                + (f"; it adds {', '.join(extra)}" if extra else "")
                + ": give records with the same measured channels", field="file")


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
    same_channels(records)
    parts: dict[str, list[Arr]] = {}
    rec_idx: list[npt.NDArray[np.int64]] = []
    phases: list[npt.NDArray[np.str_]] = []
    times: list[Arr] = []
    w = max(5, round(window * rate) | 1)
    for i, r in enumerate(records):
        t, ch, phase = _uniform(r, rate)
        measured = _measured(r, t, (w // 2) / rate)
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
        if all(c in ch for c in HOSE):
            # on the raw samples, across the valve switch (every term is a state of the
            # graph, continuous there)
            derivs.update(hose_integrals(t, ch["P2"], ch["P_valve_B"], ch["Q_meter_C"]))
            # a window that reaches into a gap integrates the interpolation across it
            lost = np.concatenate([[0], np.cumsum(~measured)])
            n = round(HOSE_WINDOW * rate)
            idx = np.arange(t.size)
            derivs["hose.ok"] = derivs["hose.ok"] * (
                lost[idx + 1] - lost[np.maximum(idx - n, 0)] == 0)
        ch = smooth
        ch.update(derivs)
        values = rig.values(condition=cond)
        # the rig's μ at this temperature, with any fluid correction it carries (a fitted
        # viscosity law of an augmented rig)
        ch["mu"] = np.full(t.size, values["fluid.mu"])
        ch["measured"] = measured.astype(float)
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
                   np.concatenate(phases), np.concatenate(times), [r.name for r in records],
                   rate)
