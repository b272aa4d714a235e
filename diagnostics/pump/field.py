"""Duty-cycle validation of a gear pump model against a field record (paper 000 §4-5).

:func:`predict` drives the base model — the bond graph of paper 000 Figure 7 with the hoses
and the relief valve (:mod:`sim.duty_cycle`) — by the record's pressure and temperature at
the engine speed, and returns the modelled flow and volumetric efficiency next to the
measured ones.  The sampled pressure is upsampled twice by a shape-preserving cubic (PCHIP)
before it fills the model's table: a piecewise-linear input has a kink at every sample, and
each kink rings the lightly damped hose columns (their laminar R leaves ζ ≈ 0.002); on
generated records this halves the cost and cuts the input-reconstruction error of the
counting-meter flow from ≈ 0.06 % to ≈ 0.01 % rms of the flow.

:func:`residual_tests` asks whether the gap between model and record is only the
flowmeter's noise (DISCREPANCY.md, steps 2-4):

* residual ``r = q_measured/q_model − 1`` [-];
* the base model's own parameters are re-fitted first, unpenalised: a constant (speed
  indication or displacement error, paper 000 §5's offset) and the laminar-slip fraction
  ``Q_s/Q`` (a Cs scale);
* Ljung-Box (statsmodels ``acorr_ljungbox``) on what is left: is it white?
* the practical size of the structure: the RMS of the 5-sample moving average of what is
  left, less the part the flowmeter's white noise explains (its standard uncertainty is
  the ±1 % bound read as rectangular, a/√3, :mod:`diagnostics.quantity`);
* named candidates: the entries of the effect library on the field circuit
  (:func:`sim.components.effects.effects_for` of ``gear-pump-field``, balance
  ``field_flow``), each regressor built from :func:`field_signals` — the **side-plate lag**
  ``(Q_s + Q_st/2)/P·ṗ/Q`` (ṗ the Savitzky-Golay derivative of the measured pressure; raw
  differences give false discoveries, DISCREPANCY.md) and the **slip hysteresis**
  ``−s·(Q_s + Q_st)/Q`` (s the direction of the last pressure change, from a play of
  half-width ``band`` on the measured pressure) — scaled to unit RMS and tested by OLS with
  HAC (Newey-West) errors, Bonferroni-corrected.  Each term also gives the entry's
  coefficient in SI (τ [s], h [-]): the equation-error estimate that starts an
  output-error fit (:mod:`diagnostics.discrepancy.field_case`).

The record is called *structured* when Ljung-Box rejects whiteness (p < α) **and** the
structure exceeds the practical size.  Default 0.1 % of the flow: DISCREPANCY.md's 0.2 % of
full scale is for hidden effects of 2 % of full scale; here the whole slip is only 1-3 % of
the flow, and the base model's own error on generated records without hidden effects
(input reconstruction from 30 ms samples and solver: ≈ 0.01 % rms, < 0.25 % at the sharpest
ramps, benchmarks/pump_study.py) stays below 0.1 % once smoothed over 5 samples.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import statsmodels.api as sm
from scipy.interpolate import PchipInterpolator
from scipy.signal import savgol_filter
from statsmodels.stats.diagnostic import acorr_ljungbox

from diagnostics.pump.field_record import FieldRecord
from diagnostics.quantity import DEFAULT_INSTRUMENTS, InstrumentClass
from sim.components.effects import effects_for
from sim.components.gear_pump import GearPump
from sim.components.gear_pump_map import stand_in_pump
from sim.duty_cycle import CIRCUIT, DutyCycleRun, duty_cycle_model
from sim.errors import InputError

__all__ = ["CANDIDATES", "FieldPrediction", "ResidualTests", "TermTest", "direction_memory",
           "field_signals", "predict", "residual_tests"]

FloatArray = npt.NDArray[np.float64]

#: Named candidate effects and the library entry (:mod:`sim.components.effects`) of each.
CANDIDATES = {"response lag": "side_plate_lag", "hysteresis": "slip_hysteresis"}


@dataclass(frozen=True, eq=False)
class FieldPrediction:
    """Model and record side by side, at the record's samples.

    Attributes
    ----------
    t
        Sample times [s].
    q_measured, q_model
        Measured and modelled (counting-meter) flow [m³/s].
    eta_v_measured, eta_v_model
        Volumetric efficiencies ``q/(D·ω)`` [-] (paper 000 §5).
    residual
        ``q_measured/q_model − 1`` [-].
    slip_fraction, laminar_fraction
        The model's slip ``(Q_s + Q_st)/Q`` and laminar slip ``Q_s/Q`` [-].
    run
        The simulation (every model output).
    """

    t: FloatArray
    q_measured: FloatArray
    q_model: FloatArray
    eta_v_measured: FloatArray
    eta_v_model: FloatArray
    residual: FloatArray
    slip_fraction: FloatArray
    laminar_fraction: FloatArray
    run: DutyCycleRun


def predict(record: FieldRecord, pump: GearPump | None = None, *, rtol: float = 1e-4,
            upsample: int = 2, effects: Mapping[str, float] | None = None) -> FieldPrediction:
    """Simulate the duty cycle of ``record`` with the base model (module docstring), or with
    library effects added.

    Parameters
    ----------
    record
        The field record (pressure [Pa], temperature [°C], flow [m³/s], speed [rad/s]).
    pump
        The pump model (default: the stand-in map, not bench data).
    rtol
        Integrator tolerance (1e-4 keeps the solver's share of the flow error below
        0.02 % rms on the records of :mod:`diagnostics.pump.field_record`).
    upsample
        Input points per sample interval (1: the samples, linear in between).
    effects
        Library effects of the field circuit and their parameters, by full name
        (``{"side_plate_lag.tau": 0.3}``): the model with those effects added
        (:func:`sim.duty_cycle.duty_cycle_model`); default none (the base model).
    """
    if upsample < 1:
        raise InputError("upsample must be ≥ 1", field="upsample")
    pm = pump if pump is not None else stand_in_pump()
    t = record.t
    if upsample > 1:
        tt = np.linspace(t[0], t[-1], (t.size - 1) * upsample + 1)
        pp = np.asarray(PchipInterpolator(t, record.pressure)(tt), dtype=np.float64)
        th = np.interp(tt, t, record.theta)
    else:
        tt, pp, th = t, record.pressure, record.theta
    ov = dict(effects or {})
    library = tuple(sorted({k.split(".", 1)[0] for k in ov}))
    run = duty_cycle_model(library).simulate(tt, pp, th, record.speed, pm, rtol=rtol,
                                                    sample_every=upsample, overrides=ov)
    q_model = run.q_meter
    q_pump = run.outputs["pump.Q"]
    slip = (run.outputs["pump.Q_s"] + run.outputs["pump.Q_st"]) / q_pump
    qth = pm.D * record.speed
    return FieldPrediction(t=t, q_measured=record.flow, q_model=q_model,
                           eta_v_measured=record.flow / qth, eta_v_model=q_model / qth,
                           residual=record.flow / q_model - 1.0, slip_fraction=slip,
                           laminar_fraction=run.outputs["pump.Q_s"] / q_pump, run=run)


def direction_memory(pressure: npt.ArrayLike, band: float) -> FloatArray:
    """Direction of the last pressure change, +1 rising, −1 falling (a play of half-width ``band``).

    The memory ``m`` stays while the pressure is within ``±band`` [Pa] of it and is dragged
    along once it leaves; the result is ``clip((p − m)/band, −1, 1)`` [-], starting at 0.
    """
    p = np.asarray(pressure, dtype=np.float64)
    out = np.empty_like(p)
    m = float(p[0])
    for k, pk in enumerate(p):
        m = min(max(m, pk - band), pk + band)
        out[k] = (pk - m) / band
    return out


def field_signals(prediction: FieldPrediction, record: FieldRecord, *, band: float = 3.0e5,
                  window: int = 11) -> dict[str, FloatArray]:
    """Signals of the ``field_flow`` balance at the record's samples, SI.

    ``t`` sample times [s], ``P`` measured pressure [Pa], ``dP`` its Savitzky-Golay
    derivative [Pa/s] (quadratic, ``window`` samples), ``Q`` the model's pump flow
    [m³/s], ``Q_s`` and ``Q_st`` its laminar and turbulent slip [m³/s], ``direction``
    the direction of the last pressure change [-] (:func:`direction_memory` of half-width
    ``band`` [Pa]), ``r`` the residual ``q_meas/q_model − 1`` [-] and
    ``laminar_fraction`` ``Q_s/Q`` [-].
    """
    out = prediction.run.outputs
    return {"t": np.asarray(record.t, dtype=np.float64),
            "P": np.asarray(record.pressure, dtype=np.float64),
            "dP": np.asarray(savgol_filter(record.pressure, window, 2, deriv=1,
                                           delta=record.interval), dtype=np.float64),
            "Q": out["pump.Q"], "Q_s": out["pump.Q_s"], "Q_st": out["pump.Q_st"],
            "direction": direction_memory(record.pressure, band),
            "r": prediction.residual, "laminar_fraction": prediction.laminar_fraction}


@dataclass(frozen=True, slots=True)
class TermTest:
    """A candidate's test: library entry, coefficient on the unit-RMS column [-], HAC t and p,
    and the entry's coefficient in SI (``value``: τ [s] of the lag, h [-] of the hysteresis)."""

    name: str
    coef: float
    t: float
    p: float
    significant: bool
    value: float = math.nan


@dataclass(frozen=True, eq=False)
class ResidualTests:
    """Is the model-record gap only the flowmeter's noise?  (module docstring)

    Attributes
    ----------
    n
        Samples.
    mean, rms, max_abs
        Of the residual [-].
    bound
        The flowmeter's ± bound [-] and ``within_bound`` the fraction of |r| ≤ bound.
    noise_u
        Standard uncertainty of a reading [-] (bound/√3).
    refit
        Re-fitted base parameters: ``offset`` [-] and ``laminar_scale`` (Cs multiplier − 1).
    ljung_box_p
        Ljung-Box p-value at ``lags`` on the residual after the re-fit.
    structure_rms
        Practical size of the structure [-] (module docstring).
    explained_rms
        RMS of the part the candidates explain [-].
    terms
        Candidate tests.
    structured
        Ljung-Box significant and ``structure_rms ≥ practical``.
    named
        Candidate effects whose regressor is significant, when structured.
    message
        One sentence.
    """

    n: int
    mean: float
    rms: float
    max_abs: float
    bound: float
    within_bound: float
    noise_u: float
    refit: dict[str, float]
    ljung_box_p: float
    lags: int
    structure_rms: float
    explained_rms: float
    practical: float
    terms: dict[str, TermTest]
    structured: bool
    named: tuple[str, ...]
    message: str


def _unit_rms(x: FloatArray) -> FloatArray:
    s = float(np.sqrt(np.mean(x * x)))
    return x / s if s > 0.0 else x


def residual_tests(prediction: FieldPrediction, record: FieldRecord, *,
                   flowmeter: InstrumentClass = DEFAULT_INSTRUMENTS["pump_flow"],
                   lags: int = 20, alpha: float = 0.01, practical: float = 0.001,
                   band: float | None = None, window: int = 11,
                   smooth: int = 5) -> ResidualTests:
    """Whiteness, size and named candidates of the residual (module docstring).

    Parameters
    ----------
    prediction, record
        From :func:`predict` and the record it was made from.
    flowmeter
        The flowmeter's class (its relative bound sets the noise level).
    lags
        Ljung-Box lags and HAC maximum lag [samples].
    alpha
        Significance level (Bonferroni-divided among the candidates).
    practical
        Smallest structure worth naming [-] (module docstring).
    band
        Half-width of the direction memory [Pa] (default: the hysteresis entry's ``w_h``,
        3 bar).
    window
        Savitzky-Golay window [samples] of dp/dt (quadratic; 11 samples = 0.33 s).
    smooth
        Moving average [samples] over which the structure's size is measured.
    """
    r = prediction.residual
    n = r.size
    if n < 4 * max(lags, window):
        raise InputError(f"need at least {4 * max(lags, window)} samples", field="t")
    bound = flowmeter.relative_bound
    noise_u = bound / math.sqrt(3.0)
    base = np.column_stack([np.ones(n), prediction.laminar_fraction])
    fit0 = sm.OLS(r, base).fit()
    left = r - fit0.fittedvalues
    lb = acorr_ljungbox(left, lags=[lags], return_df=True)
    lb_p = float(lb["lb_pvalue"].iloc[0])
    ma = np.convolve(left, np.ones(smooth) / smooth, mode="valid")
    excess = float(np.mean(ma * ma)) - noise_u**2 / smooth
    structure = math.sqrt(max(excess, 0.0))
    library = effects_for(CIRCUIT)
    if band is None:
        decl = library["slip_hysteresis"].parameter("w_h")
        band = decl.default if decl is not None else 3.0e5
    sig = field_signals(prediction, record, band=band, window=window)
    raw = {name: library[name].entry.regressor(sig) for name in CANDIDATES.values()}
    cand = {name: _unit_rms(col) for name, col in raw.items()}
    X = np.column_stack([base, *cand.values()])
    fit = sm.OLS(r, X).fit(cov_type="HAC", cov_kwds={"maxlags": lags})
    explained = X[:, 2:] @ fit.params[2:]
    explained_rms = float(np.sqrt(np.mean((explained - explained.mean()) ** 2)))
    level = alpha / len(cand)
    terms = {}
    for i, name in enumerate(cand, start=2):
        p = float(fit.pvalues[i])
        scale = float(np.sqrt(np.mean(raw[name] ** 2))) or 1.0
        terms[name] = TermTest(name, float(fit.params[i]), float(fit.tvalues[i]), p, p < level,
                               float(fit.params[i]) / scale)
    structured = lb_p < alpha and structure >= practical
    named = tuple(eff for eff, entry in CANDIDATES.items()
                  if structured and terms[entry].significant)
    if not structured:
        msg = (f"residual consistent with flowmeter noise (Ljung-Box p = {lb_p:.3g}, "
               f"structure {structure * 100:.3f} % < {practical * 100:g} % or not significant)")
    else:
        msg = (f"structured residual (Ljung-Box p = {lb_p:.3g}, size {structure * 100:.3f} %): "
               + (", ".join(named) if named else "no candidate explains it (outside the library)"))
    return ResidualTests(
        n=n, mean=float(r.mean()), rms=float(np.sqrt(np.mean(r * r))),
        max_abs=float(np.abs(r).max()), bound=bound,
        within_bound=float(np.mean(np.abs(r) <= bound)), noise_u=noise_u,
        refit={"offset": float(fit0.params[0]), "laminar_scale": float(-fit0.params[1])},
        ljung_box_p=lb_p, lags=lags, structure_rms=structure, explained_rms=explained_rms,
        practical=practical, terms=terms,
        structured=structured, named=named, message=msg)
