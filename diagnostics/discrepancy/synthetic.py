"""Synthetic measurements: a rig's simulated cycle sampled like a data logger, with noise.

Used by the hidden-effect bench and the tests: the data come from a rig *with* an effect,
the workflow starts from the rig *without* it.  Noise kinds: ``gaussian`` (σ per
channel), ``proportional`` (σ × |reading| / full scale + a floor of σ/4),
``heavy`` (Student t with 3 degrees of freedom scaled to the same σ) and ``coloured``
(what a logger's anti-alias filter or a transmitter's damping gives: first-order AR(1)
noise, φ = :data:`COLOURED_PHI` per sample, of marginal σ, and on the pressures 50 Hz
mains hum of :data:`HUM` σ amplitude at a random phase).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from diagnostics.discrepancy.noise import ar1_noise
from diagnostics.discrepancy.simulate import on_grid, phase_segments, simulate
from diagnostics.timeseries import SeriesRecord
from sim.rigs.assembly import Condition, Rig

if TYPE_CHECKING:
    from diagnostics.pump.data import BenchData

__all__ = ["CHANNELS", "COLOURED_PHI", "DWELLS", "HUM", "NOISE", "SENSORS", "UNITS",
           "channels_for", "effect_peak", "synthesize", "synthesize_bench"]

Arr = npt.NDArray[np.float64]

#: channels a rig logger records, with their SI unit
UNITS: dict[str, str] = {"x": "m", "v": "m/s", "P1": "Pa", "P2": "Pa", "P_pump": "Pa",
                         "P_valve_P": "Pa", "Q_meter_B": "m^3/s", "Q_meter_C": "m^3/s",
                         "P_valve_B": "Pa"}
#: the paper-002 logger's channels (``P_valve_B`` is an extra sensor, :data:`SENSORS`)
CHANNELS = tuple(c for c in UNITS if c != "P_valve_B")
#: extra sensors an effect needs to leave an equation-error signature: unsteady line
#: friction shows in hose B's effort balance, which needs the pressure at valve port B
SENSORS: dict[str, tuple[str, ...]] = {"line_unsteady_friction": ("P_valve_B",)}

#: default sensor noise σ per channel [SI]: 0.05 bar, 1 mm/s, 0.1 mm, 0.05 L/min
NOISE: dict[str, float] = {"x": 1e-4, "v": 1e-3, "P1": 5e3, "P2": 5e3, "P_pump": 5e3,
                           "P_valve_P": 5e3, "Q_meter_B": 8.3e-7, "Q_meter_C": 8.3e-7,
                           "P_valve_B": 5e3}


#: AR(1) coefficient per sample of the ``coloured`` noise (a 9.5 ms time constant at 1 kHz)
COLOURED_PHI = 0.9
#: amplitude of the ``coloured`` noise's 50 Hz hum on the pressures, in units of σ [-]
HUM = 0.6


def channels_for(effects: Sequence[str] = ()) -> tuple[str, ...]:
    """The logger's channels plus the extra sensors the ``effects`` need (:data:`SENSORS`)."""
    extra = [c for e in effects for c in SENSORS.get(e, ()) if c not in CHANNELS]
    return CHANNELS + tuple(dict.fromkeys(extra))

#: dwell records of the hidden-effect bench's test design: (load [N], oil temperature
#: [°C], pump speed [fraction of the stated], working-phase switch [s]).  The stroke runs
#: into its stop and is held there about 1.5 s before the timed switch, the pump flow over
#: the relief valve: at 40 °C the relief passes about 3, 10 and 16 L/min at 50, 75 and
#: 100 % speed (the rest leaks through the piston and the valve), three levels of the
#: relief flow, enough to tell an override ∝ Q² from a re-fitted setting and slope
#: (:mod:`diagnostics.discrepancy.balances`, ``relief_flow``).  The last, at the highest
#: load, is the one the workflow holds out (about 11 L/min at 50 °C).
DWELLS: tuple[tuple[float, float, float, float], ...] = (
    (2100.0, 40.0, 0.5, 6.7), (2100.0, 40.0, 0.75, 4.8), (4200.0, 40.0, 1.0, 4.1),
    (6300.0, 50.0, 1.0, 4.6))


def synthesize(rig: Rig, condition: Condition, *, rng: np.random.Generator,
               name: str = "record", rate: float = 1000.0, noise: str = "gaussian",
               sigma: Mapping[str, float] | None = None,
               overrides: Mapping[str, float] | None = None,
               channels: Sequence[str] = CHANNELS, t_max: float | None = None) -> SeriesRecord:
    """One simulated cycle sampled at ``rate`` [Hz] with sensor noise (module docstring).

    ``t_max`` [s] switches each phase after that long at the latest (a timed slow-motion
    stroke, :func:`~diagnostics.discrepancy.simulate.timed_switch`); ``sigma`` of 0 gives
    the noise-free truth.
    """
    table = simulate(rig, condition, overrides, t_max)
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
        elif noise == "coloured":
            e = ar1_noise(rng, v.size, s, COLOURED_PHI)
            if UNITS[c] == "Pa":
                e = e + HUM * s * np.sin(2.0 * np.pi * 50.0 * t + rng.uniform(0.0, 2.0 * np.pi))
        else:
            raise ValueError(f"unknown noise kind {noise!r}")
        chans[c] = v + e
    ts = table["t [s]"].to_numpy(dtype=float)
    idx = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, ts.size - 1)
    phase = table["phase"].to_numpy(dtype=str)[idx]
    cond = {"load": condition.load, "back_pressure": condition.back_pressure,
            "oil_temperature": condition.oil_temperature}
    if condition.pump_speed is not None:
        cond["pump_speed"] = condition.pump_speed
    return SeriesRecord(name, t, chans, {c: UNITS[c] for c in chans}, phase, cond,
                        measured=False)


def effect_peak(truth_table: object, base_table: object, *, rate: float = 1000.0,
                sigma: Mapping[str, float] | None = None,
                channels: Sequence[str] = CHANNELS,
                stroke: float = 0.5) -> tuple[float, str]:
    """Largest |with − without| over channels in units of that channel's noise σ.

    Returns ``(peak / σ, channel)``: the effect's size as the bench states it.  Each phase
    is cut where the piston reaches its stop (``stroke`` [m]): the motion and, in a dwell
    record, the dwell at the stop (where the relief passes the pump flow) are compared
    each on the time since its own start, over 10-90 % of the shorter of the two
    durations (steady motion, steady dwell), so that a start-up transient or a shifted
    end-stop arrival (a changed stroke time) does not count as a difference of many σ.
    An extra sensor (:data:`SENSORS`: the valve-port pressure of unsteady line friction)
    is compared over the whole of each segment, switch transients included: it is logged
    for the transient signature of its effect, which does not shift the switch times.
    """
    import pandas as pd

    assert isinstance(truth_table, pd.DataFrame) and isinstance(base_table, pd.DataFrame)
    sig = dict(NOISE) | dict(sigma or {})
    chans = [c for c in channels if c != "x"]
    best, where = 0.0, ""
    for phase in ("working", "return"):
        for a_rel, b_rel in zip(phase_segments(truth_table, phase, stroke),
                                phase_segments(base_table, phase, stroke), strict=False):
            assert isinstance(a_rel, pd.DataFrame) and isinstance(b_rel, pd.DataFrame)
            span = min(float(a_rel["t [s]"].iloc[-1]), float(b_rel["t [s]"].iloc[-1]))
            for c in chans:
                lo, hi = (0.0, 1.0) if c not in CHANNELS else (0.1, 0.9)
                t = np.arange(lo * span, hi * span, 1.0 / rate)
                diff = on_grid(a_rel, t, [c])[c] - on_grid(b_rel, t, [c])[c]
                peak = float(np.max(np.abs(diff), initial=0.0)) / sig[c]
                if peak > best:
                    best, where = peak, c
    return best, where


def synthesize_bench(rig: Rig, *, rng: np.random.Generator,
                     effects: Mapping[str, float] | None = None,
                     speeds: Sequence[float] = (0.5, 0.75, 1.0, 1.25),
                     pressures: Sequence[float] = (5e5, 1e6, 2e6, 3e6, 4e6, 5e6),
                     temperatures: Sequence[float] = (40.0, 50.0, 60.0), repeats: int = 2,
                     noise: str = "gaussian", sigma_q: float = NOISE["Q_meter_B"],
                     sigma_p: float = NOISE["P_pump"],
                     overrides: Mapping[str, float] | None = None,
                     extra_flow: Callable[[Mapping[str, Arr]], Arr] | None = None
                     ) -> BenchData:
    """Steady pump test points of the rig's pump, as a pump bench records them.

    The flow is the pump-outlet 0-junction at steady state (paper 002 eqs. 1-5, Ṗ = 0),
    ``q = ω·Vp − Δp/Rlp − Σ k·x_k``, with each hidden effect ``k`` (effect name →
    coefficient [SI]) entering through its catalogue signature ``x_k`` — for the pump
    entries the element's own flow law at steady state.  Grid: ``speeds`` (fractions of the
    stated speed) × ``pressures`` [Pa] × ``temperatures`` [°C] × ``repeats``; the logged
    pressure has noise ``sigma_p`` [Pa], the flow ``sigma_q`` [m³/s] (kinds as
    :func:`synthesize`).  ``overrides`` change the truth's base parameters (drift).
    ``extra_flow`` is a flow [m³/s] taken off the delivered one at every point, a function of
    the grid's noise-free signals — the mapping a library entry's regressor reads
    (``P_pump``, ``speed``, ``Vp``, ``mu``, ``T``, ``dP_pump``; SI) — for an effect that is
    not in the library (the design notes' Δp^1.5·ω^0.5/μ^0.3 term,
    :mod:`benchmarks.discrepancy_prototype`).
    """
    from diagnostics.pump.data import BenchData
    from sim.components.effects import EFFECTS

    v = rig.values() | dict(overrides or {})
    grid = [(w * v["pump.speed"], p, T) for w in speeds for p in pressures
            for T in temperatures for _ in range(repeats)]
    omega = np.array([g[0] for g in grid])
    dp = np.array([g[1] for g in grid])
    theta = np.array([g[2] for g in grid])
    sig = {"P_pump": dp, "speed": omega, "Vp": np.full(dp.size, v["pump.Vp"]),
           "dP_pump": np.zeros(dp.size), "T": theta,
           "mu": np.array([rig.fluid.dynamic_viscosity(float(t)) for t in theta])}
    q = omega * v["pump.Vp"] - dp / v["pump.Rlp"]
    for name, k in (effects or {}).items():
        q = q - k * np.asarray(EFFECTS[name].entry.regressor(sig), dtype=float)
    if extra_flow is not None:
        q = q - np.asarray(extra_flow(sig), dtype=float)

    def draw(s: float, x: Arr) -> Arr:
        if noise == "gaussian":
            return rng.normal(0.0, s, x.size)
        if noise == "proportional":
            return rng.normal(0.0, 1.0, x.size) * (s * np.abs(x) / np.max(np.abs(x)) + s / 4)
        if noise == "heavy":
            return rng.standard_t(3, x.size) * s / np.sqrt(3.0)
        raise ValueError(f"unknown noise kind {noise!r}")

    rep = np.array([i % repeats for i in range(len(grid))], dtype=np.int64)
    return BenchData(p_in=np.zeros(dp.size), p_out=dp + draw(sigma_p, dp), omega=omega,
                     theta=theta, q=q + draw(sigma_q, q), replicate=rep, simulated=True,
                     provenance="hydrodiag synthesize_bench (rig pump, steady state)")
