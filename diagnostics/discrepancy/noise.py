"""The sensors' noise, white or coloured, estimated from the measured records themselves.

The workflow judges every gap in units of the noise σ of each channel
(:mod:`~diagnostics.discrepancy.verdict`).  The sample-to-sample estimate
(:func:`~diagnostics.discrepancy.signals.noise_sigma`, the MAD of second differences)
is the efficient one for white noise, and it is blind to colour: a logger's anti-alias
filter or a transmitter's damping makes the noise of neighbouring samples alike, and for
first-order (AR(1)) noise with φ = 0.9 per sample it reads 0.26 of the noise's true σ,
so a model that was exact showed every channel at ~3.5 "σ" and was called
"unexplained" (a modelling engineer's pass, ``/work/notes/s43/discrepancy_findings.md``).

The noise's own σ, whatever its colour, is what second differences at a lag longer than
its correlation time see: for AR(1) noise
``Var(x[t+k] − 2x[t] + x[t−k]) = σ²·(6 − 8φᵏ + 2φ²ᵏ) → 6σ²`` once φᵏ is small.  A
channel's coloured estimate averages these variances over the lags
:data:`LAGS` (20-40 ms): over a whole period of 50 Hz mains hum its
``(2 − 2cos ωkh)²`` averages to 6, so hum counts at its own RMS, and 40 ms is short
against a hydraulic cycle's steady phases (the MAD's median keeps the switches'
transients out).  A channel is taken as coloured when that estimate exceeds the
sample-to-sample one by :data:`COLOURED`: the white, reading-proportional and t₃ noise
records of the hidden-effect bench read a median 1.10 and at most 1.19 (the switches'
ringing), AR(1) noise with φ = 0.5 reads 1.55 (``/work/notes/s44/colour_ratio.py``).
Otherwise the white estimate stands, so white-noise records are judged exactly as
before, and so are records not sampled uniformly (a solver's own points, whose lags in
samples are no lags in time); colour below the threshold (φ ≲ 0.4) leaves σ at most
~30 % low, which moves a gap judged at 3 σ less than the noise itself does.

Where noise is coloured, its averages over the 50 ms with which a balance's residual is
judged (:func:`~diagnostics.discrepancy.verdict.structured`) are larger than white noise
of the same σ would give; :func:`propagated_floors` measures that for each balance by
evaluating it again on the records with a surrogate of their noise added (AR(1) with each
channel's σ and φ, seeded) and taking the 50 ms-averaged RMS of the difference.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from scipy.ndimage import uniform_filter1d
from scipy.signal import lfilter

from diagnostics.discrepancy.balances import STRUCTURE_SMOOTH, BalanceData
from diagnostics.discrepancy.signals import Signals, noise_sigma
from diagnostics.timeseries import SeriesRecord

__all__ = ["COLOURED", "LAGS", "Noise", "ar1_noise", "coloured_note", "noise_models", "propagated_floors",
           "sigmas", "with_noise"]

Arr = npt.NDArray[np.float64]

#: lags [s] over which the coloured estimate averages its second differences' variance
LAGS = (0.020, 0.040)
#: ratio of the coloured to the white estimate above which a channel's noise is coloured [-]
COLOURED = 1.4


@dataclass(frozen=True)
class Noise:
    """A channel's noise: σ [SI unit of the channel] and its AR(1) coefficient per sample
    of the records' own sampling [-] (0: white)."""

    sigma: float
    phi: float = 0.0
    #: the sample-to-sample (white) estimate [SI unit], kept for the report
    white: float = 0.0

    @property
    def coloured(self) -> bool:
        return self.phi > 0.0


def _mad_sigma(d: Arr) -> float:
    return float(np.median(np.abs(d - np.median(d))) / 0.6745)


def coloured_sigma(x: Arr, dt: float) -> float:
    """√(mean over the lags k of :data:`LAGS` of Var(x[t+k] − 2x[t] + x[t−k]) / 6), each
    variance from the MAD [SI unit of ``x``]; 0 when the record is too short (fewer than
    8 lags' worth of samples)."""
    x = np.asarray(x, dtype=float)
    if dt <= 0 or not math.isfinite(dt):
        return 0.0
    lo = max(2, round(LAGS[0] / dt))
    hi = max(lo, round(LAGS[1] / dt))
    hi = min(hi, x.size // 8)
    if hi < lo:
        return 0.0
    # about ten lags, evenly over the range (a 50 Hz period at 1 kHz is 20 of them)
    step = max(1, (hi - lo) // 10)
    v = [_mad_sigma(x[2 * k:] - 2.0 * x[k:-k] + x[:-2 * k]) ** 2 / 6.0
         for k in range(lo, hi + 1, step)]
    return math.sqrt(float(np.mean(v)))


def _phi(ratio: float) -> float:
    """AR(1) φ whose sample-to-sample estimate reads ``ratio`` of its σ:
    (6 − 8φ + 2φ²)/6 = ratio², the root in [0, 1)."""
    r2 = min(max(ratio, 0.0), 1.0) ** 2
    return float(min(max(2.0 - math.sqrt(16.0 - 12.0 * (1.0 - r2)) / 2.0, 0.0), 0.999))


def noise_model(record: SeriesRecord, channel: str) -> Noise:
    """The noise of one channel of one record (module docstring)."""
    x = np.asarray(record.channels[channel], dtype=float)
    white = noise_sigma(x)
    if record.sample_rate is None:
        # lags counted in samples are no time lags where the steps vary (a solver's own
        # points, 0.1 ns to 50 ms apart): the 20-40 ms "lags" spanned whole strokes and a
        # noise-free cycle read P1's noise 0.86 bar, 350× its own, and its 15 % worn
        # spool "no effect" (a maintenance planner's pass); a logger samples uniformly
        return Noise(white, 0.0, white)
    col = coloured_sigma(x, 1.0 / record.sample_rate)
    if white > 0 and col > COLOURED * white:
        return Noise(col, _phi(white / col), white)
    return Noise(white, 0.0, white)


def noise_models(records: Sequence[SeriesRecord], channels: Sequence[str]
                 ) -> dict[str, Noise]:
    """Each channel's noise over the records: the median σ, φ and white σ of the records
    (white when most records' channel is)."""
    out: dict[str, Noise] = {}
    for c in channels:
        each = [noise_model(r, c) for r in records]
        phi = float(np.median([n.phi for n in each]))
        out[c] = Noise(float(np.median([n.sigma for n in each])), phi,
                       float(np.median([n.white for n in each])))
        if phi == 0.0:
            out[c] = Noise(out[c].white, 0.0, out[c].white)
    return out


def sigmas(records: Sequence[SeriesRecord], channels: Sequence[str],
           models: Mapping[str, Noise] | None = None) -> dict[str, float]:
    """Noise σ per channel [SI], at least 1e-4 of the channel's largest |value| (a channel
    logged without noise would otherwise divide by zero)."""
    models = models if models is not None else noise_models(records, channels)
    out = {}
    for c in channels:
        scale = float(np.max([np.max(np.abs(r.channels[c])) for r in records]))
        out[c] = max(models[c].sigma, 1e-4 * scale, 1e-30)
    return out


def ar1_noise(rng: np.random.Generator, size: int, sigma: float, phi: float) -> Arr:
    """Stationary first-order noise ``x[t] = φ·x[t−1] + e[t]``, ``e ~ N(0, σ²(1 − φ²))``,
    started from ``x ~ N(0, σ²)``: marginal σ [unit of ``sigma``], lag-k autocorrelation
    φᵏ; white for φ = 0 (the surrogate of :func:`with_noise`, the synthetic logger's
    ``coloured`` kind)."""
    e = rng.normal(0.0, sigma * math.sqrt(1.0 - phi ** 2), size)
    x0 = rng.normal(0.0, sigma)
    return np.asarray(lfilter([1.0], [1.0, -phi], e, zi=np.array([phi * x0]))[0], dtype=float)


def with_noise(records: Sequence[SeriesRecord], models: Mapping[str, Noise], seed: int = 0
               ) -> list[SeriesRecord]:
    """The records with a surrogate of their noise added: stationary AR(1) noise with each
    channel's σ and φ (white where φ = 0), seeded."""
    rng = np.random.default_rng(seed)
    out = []
    for r in records:
        ch = dict(r.channels)
        for c, n in models.items():
            if c not in ch or n.sigma <= 0:
                continue
            ch[c] = np.asarray(ch[c], dtype=float) + ar1_noise(rng, ch[c].size, n.sigma,
                                                                n.phi)
        out.append(replace(r, channels=ch))
    return out


def propagated_floors(data: Sequence[BalanceData], clean: Signals, noisy: Signals,
                      values: dict[str, float]) -> dict[str, float]:
    """Per balance, the RMS that the surrogate noise alone gives its target once averaged
    over :data:`~diagnostics.discrepancy.balances.STRUCTURE_SMOOTH` samples [unit of the
    balance]: the balance built on the same kept samples of ``noisy`` (the records with
    :func:`with_noise`) and of ``clean``, differenced.  The base columns' noise times
    their coefficients is left out: on the reference rig it is orders below the target's
    (the flowmeters' and the pressures' own noise)."""
    out: dict[str, float] = {}
    for d in data:
        y0, _ = d.balance.build(clean.subset(d.mask), values)
        yn, _ = d.balance.build(noisy.subset(d.mask), values)
        diff = np.asarray(yn - y0, dtype=float)
        if diff.size == 0:
            continue
        smooth = uniform_filter1d(diff, STRUCTURE_SMOOTH)
        out[d.balance.name] = float(np.sqrt(np.mean(smooth ** 2)))
    return out


def coloured_note(models: Mapping[str, Noise], derived: Collection[str] = ()) -> str:
    """'sensor noise coloured on P1, P2 (σ 3.9-4.1× the sample-to-sample estimate): …',
    or '' when every channel's noise is white.  A channel in ``derived`` (the piston speed
    the workflow derives from the position) is named apart: its colour is the derivative's
    smoothing, not a sensor's (a discrepancy pass read "sensor noise coloured on v" for a
    speed no sensor logged)."""
    col = [(c, n) for c, n in models.items() if n.coloured and n.white > 0]
    if not col:
        return ""
    ratios = [n.sigma / n.white for _, n in col]
    span = (f"{min(ratios):.1f}" if f"{min(ratios):.1f}" == f"{max(ratios):.1f}"
            else f"{min(ratios):.1f}-{max(ratios):.1f}")
    sensed = [c for c, _ in col if c not in derived]
    made = [c for c, _ in col if c in derived]
    what = " and ".join(
        ([f"sensor noise coloured on {', '.join(sensed)}"] if sensed else [])
        + ([f"noise coloured on {', '.join(made)}, derived from the position (the "
            "derivative's smoothing colours it)"] if made else []))
    return (f"{what} (σ {span}× the sample-to-sample estimate): gaps are judged against the "
            "noise's own σ (second differences at 20-40 ms lags) and the balances' noise "
            "floors against a surrogate of that noise")
