"""The laminar slip coefficient Cs implied by field records, and its trend over a campaign.

A visit to the machine gives two duty-cycle records at the same engine speed: one with cold
oil (a morning start) and one with warm oil.  Paper 000 eq. 7 then gives Cs at every
pressure level both records hold steadily, without the bench's Cst, β_ef or the engine
speed's absolute value (:func:`diagnostics.slip.slip_coefficient_two_temperatures`)::

    Cs = (q₁ − q₂) / (Δp·D·(1/μ₂ − 1/μ₁))                                   (eq. 7)

1. **Plateaus** (:func:`plateaus`): runs where the Savitzky-Golay derivative of the measured
   pressure stays below ``max_rate`` for at least ``min_duration`` after ``settle`` (the
   hose compliance's flow ``C·dp/dt`` and the side plate's response die out there).
2. **Levels**: plateau pressures of both records grouped by
   :func:`diagnostics.pump.levels.cluster_levels`; a level present in both records gives
   one eq. 7 pair of pooled means.
3. **Uncertainties** of the pooled means (GUM; bounds read as rectangular,
   :mod:`diagnostics.quantity`): the flow, ``(a/√3)·q̄/√N`` — the flowmeter noise is
   independent from sample to sample, so it averages down; a gain error of the meter
   common to both records would scale Cs by the same fraction and leaves the *trend*
   unchanged; the pressure, the transducer's class bound (a gain, not averaged); the
   temperature, the thermometer's class; the speed, one engine reading shared by both
   records, so its error cancels in eq. 7's speed correction ``D·(ω₁ − ω₂)`` and it
   enters with ``u = 0``.
4. **Campaign** (:func:`campaign_trend`): the visits' Cs at one level as a
   :class:`diagnostics.trends.TrendSeries`; Theil-Sen slope and time to a threshold
   (:func:`diagnostics.trends.forecast_threshold`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.pump.field_record import FieldRecord
from diagnostics.pump.levels import cluster_levels
from diagnostics.quantity import DEFAULT_INSTRUMENTS, InstrumentClass, Quantity
from diagnostics.slip import slip_coefficient_two_temperatures
from diagnostics.trends import ThresholdForecast, TrendSeries, forecast_threshold
from diagnostics.uncertainty import Estimate
from sim.components.gear_pump import GearPump
from sim.errors import InputError, MeasurementError

__all__ = ["CampaignTrend", "LevelSlip", "Plateau", "campaign_trend", "plateaus",
           "visit_slip"]


#: Time span of the derivative window of :func:`plateaus` [s]: 11 samples at paper 000's
#: 30 ms sampling (§3.2.2), the setting the defaults were tuned with.
DERIVATIVE_SPAN = 0.33


@dataclass(frozen=True, slots=True)
class Plateau:
    """A steady stretch of a record: times [s], samples, means (pressure [Pa], flow [m³/s], θ [°C])."""

    start: float
    end: float
    n: int
    pressure: float
    flow: float
    theta: float


def plateaus(record: FieldRecord, *, max_rate: float = 2.0e6, min_duration: float = 1.0,
             settle: float = 0.5, window: int | None = None) -> list[Plateau]:
    """Steady stretches of ``record`` (module docstring, step 1).

    Parameters
    ----------
    record
        The field record.
    max_rate
        Largest |dp/dt| [Pa/s] of a steady sample (default 20 bar/s: the operator's slow
        oscillation passes, a ramp does not).
    min_duration
        Shortest plateau kept, after settling [s].
    settle
        Time dropped at the start of each steady run [s].
    window
        Savitzky-Golay window of the derivative [samples]; default: the odd number of
        samples spanning :data:`DERIVATIVE_SPAN` at the record's own rate (11 at paper
        000's 30 ms), at least 5.

    Warns
    -----
    UserWarning
        When the derivative window spans more than ``min_duration``: the record is
        sampled too coarsely for these settings (a 1 Hz record would merge a whole cycle
        into one plateau) — pass settings scaled to its rate.
    """
    dt = record.interval
    if window is None:
        window = max(5, 2 * round(DERIVATIVE_SPAN / dt / 2) + 1)
    if window * dt > min_duration:
        warnings.warn(f"plateaus(): the derivative window ({window} samples = {window * dt:.3g} "
                      f"s at {1.0 / dt:.3g} Hz) is longer than min_duration ({min_duration} "
                      "s); the record is too coarse for these settings", stacklevel=2)
    if record.pressure.size < window:
        return []
    dpdt = savgol_filter(record.pressure, window, 2, deriv=1, delta=dt)
    steady = np.abs(dpdt) < max_rate
    edges = np.flatnonzero(np.diff(np.concatenate([[0], steady.astype(np.int8), [0]])))
    out = []
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        keep = np.arange(a, b)[record.t[a:b] >= record.t[a] + settle]
        if keep.size < 2 or record.t[keep[-1]] - record.t[keep[0]] < min_duration:
            continue
        out.append(Plateau(float(record.t[keep[0]]), float(record.t[keep[-1]]), int(keep.size),
                           float(record.pressure[keep].mean()), float(record.flow[keep].mean()),
                           float(record.theta[keep].mean())))
    return out


@dataclass(frozen=True, slots=True)
class LevelSlip:
    """Cs at one pressure level of a visit: level [Pa], the eq. 7 estimate, samples used."""

    level: float
    estimate: Estimate
    n_cold: int
    n_warm: int


def _pooled(group: Sequence[Plateau], record: FieldRecord, rig_id: str,
            flowmeter: InstrumentClass, transducer: InstrumentClass,
            thermometer: InstrumentClass) -> MeasurementRecord:
    n = sum(p.n for p in group)
    q = sum(p.n * p.flow for p in group) / n
    dp = sum(p.n * p.pressure for p in group) / n
    th = sum(p.n * p.theta for p in group) / n
    u_q = flowmeter.relative_bound / np.sqrt(3.0) * abs(q) / np.sqrt(n)
    # OperatingCondition needs a load or back-pressure (paper 002's rig fields): a pump point
    # has none, its return goes to tank at 0 bar gauge.
    cond = OperatingCondition(oil_temperature=thermometer.reading(th),
                              back_pressure=Quantity(0.0, 0.0),
                              pump_speed=Quantity(record.speed, 0.0))
    return MeasurementRecord(rig_id=rig_id, condition=cond, pump_pressure=transducer.reading(dp),
                             pump_flow=Quantity(q, float(u_q)))


def visit_slip(cold: FieldRecord, warm: FieldRecord, pump: GearPump, *,
               rig_id: str = "field", rel_gap: float = 0.05,
               flowmeter: InstrumentClass = DEFAULT_INSTRUMENTS["pump_flow"],
               transducer: InstrumentClass = DEFAULT_INSTRUMENTS["pump_pressure"],
               thermometer: InstrumentClass = DEFAULT_INSTRUMENTS["condition.oil_temperature"],
               max_rate: float = 2.0e6, min_duration: float = 1.0,
               settle: float = 0.5) -> list[LevelSlip]:
    """Cs by eq. 7 at every pressure level both records of a visit hold (module docstring).

    Parameters
    ----------
    cold, warm
        Records of one visit at the same engine speed, with clearly different oil
        temperatures.
    pump
        Gives D [m³/rad] and the oil (μ(θ)); its coefficient surfaces are not used.
    rig_id
        Name of the machine in the measurement records.
    rel_gap
        Relative gap that separates two pressure levels [-].
    flowmeter, transducer, thermometer
        Instrument classes (defaults: paper 000 §3.2.1 and the project's thermometer).
    max_rate, min_duration, settle
        Plateau selection (:func:`plateaus`).

    Returns
    -------
    list of LevelSlip
        One per level, lowest first; a level whose pair eq. 7 refuses (pressures that do not
        agree within their uncertainties) is left out.

    Raises
    ------
    InputError
        Different engine speeds.
    """
    if cold.speed != warm.speed:
        raise InputError("eq. 7 needs both records at the same engine speed", field="speed")
    pc, pw = (plateaus(r, max_rate=max_rate, min_duration=min_duration, settle=settle)
              for r in (cold, warm))
    if not pc or not pw:
        return []
    idx, levels = cluster_levels([p.pressure for p in pc + pw], rel_gap=rel_gap,
                                 field="pressure")
    out = []
    for lev, value in enumerate(levels):
        gc = [p for p, i in zip(pc, idx[: len(pc)], strict=True) if i == lev]
        gw = [p for p, i in zip(pw, idx[len(pc):], strict=True) if i == lev]
        if not gc or not gw or value <= 0.0:
            continue
        a = _pooled(gc, cold, rig_id, flowmeter, transducer, thermometer)
        b = _pooled(gw, warm, rig_id, flowmeter, transducer, thermometer)
        try:
            est = slip_coefficient_two_temperatures(a, b, pump.D, fluid=pump.fluid,
                                                    method="delta")
        except MeasurementError:
            continue
        out.append(LevelSlip(float(value), est, sum(p.n for p in gc), sum(p.n for p in gw)))
    return out


@dataclass(frozen=True, slots=True)
class CampaignTrend:
    """Cs over the visits of a campaign: the series and the time left to ``threshold``."""

    series: TrendSeries
    forecast: ThresholdForecast


def campaign_trend(times: Sequence[float], estimates: Sequence[Estimate], threshold: float, *,
                   rig_id: str = "field") -> CampaignTrend:
    """Trend of Cs [-] over visits at ``times`` [s] and the time left to ``threshold`` [-].

    Cs grows as the side-plate clearance wears (paper 000 §3.1: Cs reflects the film between
    side plate and gears), so larger is worse.
    """
    series = TrendSeries.from_estimates(rig_id, "pump", times, estimates)
    return CampaignTrend(series, forecast_threshold(series, threshold, direction="increasing"))
