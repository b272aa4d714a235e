"""Pump leakage per load cycle from measured pressure and flow plateaus, its trend and its score.

The working circuit of a constant-speed pump receives the pump's geometric flow less the
internal leakage.  At a steady pressure plateau (paper 000 eq. 6, the laminar slip term)::

    q = D·ω − G·Δp,          G = Cs·D/μ(θ)                                    (eq. 6)

so the leakage conductance ``G`` [m³/(s·Pa)] at a plateau is ``(D·ω − q)/Δp``.  Neither
``D·ω`` nor ``Cs`` of the ZeMA pump is published, and the 1 Hz data carry no speed.  The
estimate therefore compares every cycle with the *healthy envelope at the same oil
temperature*, taken from the campaign itself without any label::

    q_ref(θ) = upper quantile of the plateau flows of all cycles with |θ_k − θ| ≤ w
    G_est    = (q_ref(θ) − q) / Δp                                            [m³/(s·Pa)]

At equal θ the viscosity, and with it the healthy pump's own slip ``Cs·D/μ``, is the same,
so ``G_est`` is the *extra* leakage conductance, without a viscosity law (an explicit
``1/μ(θ)`` normalisation over-corrects on this rig: oil temperature changes with the cooler
state, and more than the pump's slip changes with it).

1. **Plateaus** (:func:`record_plateaus`): samples where the pressure, averaged over
   ``span`` seconds, changes by less than ``max_rate`` [Pa/s]; every setting is in seconds
   and turned into samples at the record's own rate; ``settle`` seconds of each steady run
   are dropped; plateaus without flow (the relief valve's, all flow to tank)
   are left out.
2. **Cycle means** (:func:`cycle_point`): flow, pressure and temperature pooled over the
   plateaus of one cycle, sample-weighted.
3. **Estimate** (:func:`leakage_estimates`): ``G_est`` above, per cycle.
4. **Trend** (:func:`change_points`): mean shifts of the estimate over cycles by binary
   segmentation with a BIC penalty (a step change is what a worn or failed part gives; a
   straight-line forecast on block-wise labels is not meaningful).
5. **Score** (:func:`score_leakage`): the labels enter here only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.ndimage import uniform_filter1d
from scipy.stats import mannwhitneyu, rankdata, spearmanr

from diagnostics.real.relaxation import settled_flow
from diagnostics.sampling import uniform_rate
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError, MeasurementError

__all__ = ["CyclePoint", "LeakageScore", "change_points", "cycle_point", "leakage_estimates",
           "record_plateaus", "score_leakage", "spearman_ceiling"]

Arr = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class CyclePoint:
    """Plateau means of one cycle: pressure [Pa], flow [m³/s], oil temperature [°C], samples,
    and the number of working plateaus pooled [-] (0 where not counted)."""

    name: str
    pressure: float
    flow: float
    theta: float
    n: int
    plateaus: int = 0


def record_plateaus(record: SeriesRecord, *, pressure: str = "p_pump",
                    max_rate: float = 2.0e5, settle: float = 1.0,
                    min_duration: float = 3.0, span: float = 1.0) -> list[tuple[int, int]]:
    """Index ranges ``[a, b)`` of the steady pressure plateaus of ``record``.

    Parameters
    ----------
    record
        A uniformly sampled record (:attr:`SeriesRecord.sample_rate` not None).
    pressure
        Pressure channel [Pa].
    max_rate
        Largest |dp/dt| [Pa/s] of a steady sample (default 2 bar/s).
    settle
        Time dropped at the start of each steady run [s].
    min_duration
        Shortest plateau kept after settling [s].
    span
        Time over which the pressure is averaged before its derivative is taken [s]: the
        same span at every rate (one sample at 1 Hz, 100 samples at 100 Hz), so sensor
        noise at a high rate does not break a plateau.

    Raises
    ------
    InputError
        The record is not uniformly sampled, or is shorter than ``min_duration``.
    """
    rate = uniform_rate(record)
    p = record.channel(pressure)
    if record.duration < min_duration:
        raise InputError(f"record {record.name!r} is shorter than a plateau "
                         f"({record.duration:.3g} s < {min_duration} s)", field="t")
    width = max(1, round(span * rate))
    smooth = uniform_filter1d(p, width, mode="nearest") if width > 1 else p
    dpdt = np.gradient(smooth, 1.0 / rate)
    steady = np.abs(dpdt) < max_rate
    edges = np.flatnonzero(np.diff(np.concatenate([[0], steady.astype(np.int8), [0]])))
    skip = math.ceil(settle * rate - 1e-9)
    need = max(2, math.ceil(min_duration * rate - 1e-9))
    out = []
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        a2 = int(a) + skip
        if b - a2 >= need:
            out.append((a2, int(b)))
    return out


def cycle_point(record: SeriesRecord, *, pressure: str = "p_pump", flow: str = "q_work",
                temperature: str = "oil_temperature", min_flow_fraction: float = 0.2,
                stop_at_relief: bool = False, relaxation: float = 0.0,
                max_plateaus: int | None = None, **plateau_options: float) -> CyclePoint:
    """Flow, pressure and temperature pooled over the working plateaus of one cycle.

    A plateau whose mean flow is below ``min_flow_fraction`` [-] of the record's largest
    plateau flow is a no-flow plateau (relief valve) and is left out.  With
    ``stop_at_relief`` the working plateaus that follow a no-flow plateau *after* the first
    working plateau are left out too: once the cycle has left its load program for the
    relief valve (the line and accumulator charged to relief pressure, the oil in the pump
    heated by full-pressure throttling), its later plateaus are not in the steady state the
    healthy reference was taken in.  Every cycle then contributes the plateaus it reached
    the same way (on the ZeMA rig: all five working plateaus, or only the first one).

    ``relaxation`` [s] > 0 takes each plateau's flow as its settled value
    (:func:`~diagnostics.real.relaxation.settled_flow`, the accumulator's gas relaxation
    removed) instead of its mean; ``max_plateaus`` keeps only the first working plateaus.

    Raises
    ------
    MeasurementError
        No working plateau (``field=pressure``).
    """
    plats = record_plateaus(record, pressure=pressure, **plateau_options)
    p, q = record.channel(pressure), record.channel(flow)
    theta = (record.channel(temperature) if temperature in record.channels
             else np.full(p.size, record.condition.get("oil_temperature", math.nan)))
    means = [(a, b, float(q[a:b].mean())) for a, b in plats]
    top = max((m for _, _, m in means), default=0.0)
    keep: list[tuple[int, int]] = []
    for a, b, m in means:
        working = top > 0 and m >= min_flow_fraction * top
        if working:
            keep.append((a, b))
        elif stop_at_relief and keep:
            break
    if not keep:
        raise MeasurementError(f"record {record.name!r} has no pressure plateau with flow",
                               field=pressure)
    if max_plateaus is not None:
        keep = keep[:max(1, max_plateaus)]
    idx = np.concatenate([np.arange(a, b) for a, b in keep])
    if relaxation > 0:
        rate = record.sample_rate or 1.0
        flow_mean = sum((b - a) * settled_flow(q[a:b], relaxation * rate)
                        for a, b in keep) / idx.size
    else:
        flow_mean = float(q[idx].mean())
    return CyclePoint(record.name, float(p[idx].mean()), float(flow_mean),
                      float(theta[idx].mean()), int(idx.size), len(keep))


def leakage_estimates(points: Sequence[CyclePoint], *, window: float = 1.0,
                      quantile: float = 0.975) -> Arr:
    """Extra leakage conductance ``G_est`` [m³/(s·Pa)] of every cycle (module docstring).

    Parameters
    ----------
    points
        Cycle means of the campaign (no labels).
    window
        Half-width [°C] of the oil-temperature neighbourhood of the healthy envelope.
    quantile
        Quantile [-] of the neighbours' flows taken as healthy flow.

    Raises
    ------
    InputError
        Fewer than 2 cycles, or a non-finite temperature.
    """
    if len(points) < 2:
        raise InputError("the envelope needs at least 2 cycles", field="points")
    th = np.array([c.theta for c in points])
    if not np.all(np.isfinite(th)):
        raise InputError("every cycle needs an oil temperature", field="oil_temperature")
    q = np.array([c.flow for c in points])
    p = np.array([c.pressure for c in points])
    order = np.argsort(th)
    ths, qs = th[order], q[order]
    lo = np.searchsorted(ths, th - window, side="left")
    hi = np.searchsorted(ths, th + window, side="right")
    qref = np.array([np.quantile(qs[a:b], quantile) for a, b in zip(lo, hi, strict=True)])
    return np.asarray((qref - q) / p, dtype=np.float64)


def change_points(x: npt.ArrayLike, *, min_size: int = 20, penalty: float | None = None
                  ) -> list[int]:
    """Indices where the mean of ``x`` shifts (binary segmentation, Gaussian cost).

    A split is kept when it lowers the residual sum of squares by more than ``penalty``
    (default BIC: ``σ²·3·ln n`` with σ from the median absolute successive difference)
    and leaves at least ``min_size`` samples on each side.
    """
    v = np.asarray(x, dtype=np.float64)
    n = v.size
    if n < 2 * min_size:
        return []
    sigma = float(np.median(np.abs(np.diff(v)))) / (0.6745 * math.sqrt(2.0))
    pen = penalty if penalty is not None else max(sigma, 1e-300) ** 2 * 3.0 * math.log(n)
    found: list[int] = []
    stack = [(0, n)]
    while stack:
        a, b = stack.pop()
        seg = v[a:b]
        m = seg.size
        if m < 2 * min_size:
            continue
        c1 = np.cumsum(seg)
        c2 = np.cumsum(seg ** 2)
        k = np.arange(min_size, m - min_size + 1)
        left = c2[k - 1] - c1[k - 1] ** 2 / k
        right = (c2[-1] - c2[k - 1]) - (c1[-1] - c1[k - 1]) ** 2 / (m - k)
        total = c2[-1] - c1[-1] ** 2 / m
        gain = total - (left + right)
        j = int(np.argmax(gain))
        if gain[j] > pen:
            split = a + int(k[j])
            found.append(split)
            stack += [(a, split), (split, b)]
    return sorted(found)


def spearman_ceiling(labels: npt.ArrayLike) -> float:
    """Largest Spearman ρ [-] any tie-free estimate can reach with tied ``labels``."""
    y = np.asarray(labels, dtype=np.float64)
    best = rankdata(y, method="ordinal")
    return float(spearmanr(y, best)[0])


@dataclass(frozen=True, slots=True)
class LeakageScore:
    """Scores of a leakage estimate against the labels (for reporting only).

    Attributes
    ----------
    spearman, ceiling, fraction
        Spearman ρ with the leakage class, the tie ceiling, and their ratio [-].
    auroc_01, auroc_12
        AUROC of class 0 vs 1 and 1 vs 2 [-].
    cooler_within, accumulator_within
        Spearman ρ with the cooler / accumulator label within each leakage class [-].
    """

    spearman: float
    ceiling: float
    fraction: float
    auroc_01: float
    auroc_12: float
    cooler_within: tuple[float, ...]
    accumulator_within: tuple[float, ...]

    @property
    def worst_confound(self) -> float:
        """Largest |ρ| with the cooler or accumulator label within a leakage class [-]."""
        return float(max(abs(v) for v in self.cooler_within + self.accumulator_within))

    def figures(self) -> dict[str, object]:
        """The scores as the studies' JSON reports them [-]."""
        return {"spearman": self.spearman, "fraction_of_ceiling": self.fraction,
                "auroc_0_1": self.auroc_01, "auroc_1_2": self.auroc_12,
                "cooler_within": list(self.cooler_within),
                "accumulator_within": list(self.accumulator_within),
                "worst_confound": self.worst_confound}


def _auroc(est: Arr, cls: Arr, a: float, b: float) -> float:
    xa, xb = est[cls == a], est[cls == b]
    if xa.size == 0 or xb.size == 0:
        return math.nan
    return float(mannwhitneyu(xb, xa).statistic / (xa.size * xb.size))


def _rho(x: Arr, y: Arr) -> float:
    if x.size < 3 or np.ptp(y) == 0 or np.ptp(x) == 0:
        return math.nan
    return float(spearmanr(x, y)[0])


def score_leakage(estimate: npt.ArrayLike, leakage: npt.ArrayLike, cooler: npt.ArrayLike,
                  accumulator: npt.ArrayLike) -> LeakageScore:
    """Spearman (and its tie ceiling), AUROCs and within-class confounds of an estimate."""
    est = np.asarray(estimate, dtype=np.float64)
    lk = np.asarray(leakage, dtype=np.float64)
    co = np.asarray(cooler, dtype=np.float64)
    ac = np.asarray(accumulator, dtype=np.float64)
    rho = _rho(est, lk)
    ceil = spearman_ceiling(lk)
    classes = np.unique(lk)
    cw = tuple(_rho(est[lk == c], co[lk == c]) for c in classes)
    aw = tuple(_rho(est[lk == c], ac[lk == c]) for c in classes)
    return LeakageScore(rho, ceil, rho / ceil, _auroc(est, lk, 0, 1), _auroc(est, lk, 1, 2),
                        tuple(v for v in cw if not math.isnan(v)),
                        tuple(v for v in aw if not math.isnan(v)))
