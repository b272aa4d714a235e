"""Pump leakage as an orifice plus a laminar shunt: leak size apart from the oil temperature.

On the ZeMA rig the flow deficit of a leaking pump grows as the oil warms, by nearly the
*same flow* in the weak and the severe leak setting (``make real-data``: class 2 − class 1
stays within 0.005 l/min while each moves by ~0.055 l/min between 36 and 56 °C).  A
viscosity factor on the whole leak (``G·μ^b``) cannot follow that; a leak path made of a
turbulent orifice of the setting's size and a laminar shunt common to every leaking
setting can (the shunt is paper 000 eq. 6's laminar slip term, ``Q = Cs·D·Δp/μ`` with
``λ = Cs·D``)::

    Δq = q_ref(θ, p) − q = K·√Δp + λ·Δp/μ(θ)·[leaking]                      (orifice + eq. 6)

``K`` [m³/(s·Pa^½)] is the leak size reported per cycle; nothing in it is fitted with labels:

1. **Leaking or not** (:func:`leak_threshold`): the first-pass deficits (the envelope of
   :func:`~diagnostics.real.leakage.leakage_estimates`) split at their widest gap inside the
   central 90 % of the campaign — a healthy and a leaking population.
2. **Healthy reference at the cycle's θ and p** (:func:`reference_flows`): the median flow of
   the non-leaking cycles within ±``window`` °C, each moved to the cycle's pressure with the
   healthy within-cycle slope ``dq/dp`` (:func:`plateau_slope`, median over non-leaking cycles).
3. **Shunt** (:func:`fit_shunt`): ``λ`` [m³] such that the leak sizes of the leaking cycles
   carry no rank correlation with the oil temperature.  This is an *assumption about the
   campaign*, not a label: the leak settings were applied independently of the cooler state
   (the ZeMA campaign is a factorial design).  A campaign where leaks and temperature change
   together would need ``λ`` from elsewhere (a bench test of the leak path).

**What K is relative to.**  Without a baseline, steps 1 and 2 take the healthy population
from the batch itself: ``K`` is the leak *beyond the batch's lower group*.  On a batch that
holds both a healthy and a leaking population (the whole ZeMA campaign, or any stretch of
it with healthy cycles) that is the pump's leak; on a batch of one class it is not (a
real-data analyst's pass: cycles 1-100, all healthy, flagged 11 of them; cycles 211-292,
weak and severe leaks only, read the weak leak as none and the severe one at 15 % of its
size).  So a batch whose first-pass deficits show no separate upper group — the medians of
the two sides of the widest gap less than :data:`MIN_SEPARATION` pooled robust σ apart
(healthy-only stretches of ZeMA: 2.1-2.4; mixed ones 3.8-20), or less than
:data:`MIN_LEAK_FRACTION` of the flow — is refused, and
:class:`HealthyBaseline` (cycles known healthy: those after commissioning or an overhaul)
makes ``K`` absolute: the reference flows and the slope come from the baseline, and a cycle
leaks when its deficit is more than :data:`BASELINE_Z` robust σ above the baseline's own
(each baseline cycle read against the others) and at least :data:`MIN_LEAK_FRACTION` of
the flow.  With the shunt ``λ`` given too (``shunt=``, fitted once on a campaign that spans
the oil temperatures) a cycle's ``K`` depends on nothing else in the batch; ``λ`` fitted per
batch follows the batch's temperatures (the same severe cycles read 1.15 or 1.74 ×10⁻⁹ with
it; 1.347 with the campaign's, a checker's pass).  A batch of leaking cycles only is told
from a healthy one by a baseline alone: without one, cycles 211-292 (no healthy cycle) still
read the weak leak as the batch's healthy reference.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.stats import spearmanr

from diagnostics.real.leakage import (
    CyclePoint,
    cycle_point,
    leakage_estimates,
    record_plateaus,
)
from diagnostics.robust import mad_sigma
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError

__all__ = ["BASELINE_Z", "MIN_LEAK_FRACTION", "MIN_SEPARATION", "HealthyBaseline",
           "ShuntEstimate", "fit_relaxation", "fit_shunt", "leak_threshold", "plateau_slope",
           "reference_flows", "separation", "shunt_estimates"]

Arr = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: Least separation [robust σ] of the two sides of a batch's leak split (module docstring).
MIN_SEPARATION = 3.0
#: Least difference of the two sides' median deficits, as a fraction of the batch's median
#: flow [-]: half a percent, under which a split is a flow meter's scatter (a ±1 % class
#: meter) rather than a leaking population; the weak ZeMA leak is ~3 %.  Needed beside the
#: separation on small batches spread over temperature, where the first pass's deficits
#: hold many exact zeros and their MAD is no scale (18 healthy cycles over 35-58 °C: 9.7 σ
#: apart, 0.009 l/min of 8)
MIN_LEAK_FRACTION = 0.005
#: A cycle leaks when its deficit is this many robust σ above a baseline's [-].
BASELINE_Z = 5.0
#: Robust σ of a normal sample from its median absolute deviation [-].
@dataclass(frozen=True)
class HealthyBaseline:
    """Cycles known healthy (after commissioning or an overhaul) that a batch is read
    against, so its leak sizes do not depend on which other cycles it holds.

    Attributes
    ----------
    records, points
        The healthy cycles and their plateau means
        (:func:`~diagnostics.real.leakage.cycle_point`, as the batch's).
    """

    records: Sequence[SeriesRecord]
    points: Sequence[CyclePoint]


def plateau_slope(record: SeriesRecord, *, pressure: str = "p_pump", flow: str = "q_work",
                  min_flow_fraction: float = 0.2) -> float:
    """Least-squares ``dq/dp`` [m³/(s·Pa)] over the working plateaus of one cycle; NaN with < 2 levels."""
    plats = record_plateaus(record, pressure=pressure)
    p, q = record.channel(pressure), record.channel(flow)
    pts = [(float(p[a:b].mean()), float(q[a:b].mean())) for a, b in plats]
    top = max((m for _, m in pts), default=0.0)
    work = np.array([(x, y) for x, y in pts if top > 0 and y >= min_flow_fraction * top])
    if work.shape[0] < 2 or np.ptp(work[:, 0]) < 1.0e5:
        return float("nan")
    x = work[:, 0] - work[:, 0].mean()
    return float(np.sum(x * (work[:, 1] - work[:, 1].mean())) / np.sum(x * x))


def leak_threshold(deficit: npt.ArrayLike, *, central: float = 0.9) -> float:
    """Deficit [m³/s] at the widest gap of the sorted deficits inside the central fraction.

    Raises
    ------
    InputError
        Fewer than 10 finite deficits, or ``central`` outside (0, 1].
    """
    d = np.sort(np.asarray(deficit, dtype=np.float64))
    d = d[np.isfinite(d)]
    if d.size < 10:
        raise InputError("the leak threshold needs at least 10 cycles", field="deficit")
    if not 0.0 < central <= 1.0:
        raise InputError(f"central must lie in (0, 1], got {central}", field="central")
    lo = int((1.0 - central) / 2.0 * d.size)
    hi = max(lo + 1, int((1.0 + central) / 2.0 * d.size) - 1)
    j = lo + int(np.argmax(np.diff(d)[lo:hi]))
    return float(0.5 * (d[j] + d[j + 1]))


def separation(deficit: npt.ArrayLike, threshold: float) -> float:
    """How far apart the two sides of a leak split are [robust σ]: the difference of their
    medians over the pooled robust σ (MAD) of the sides; 0 when a side is empty."""
    d = np.asarray(deficit, dtype=np.float64)
    d = d[np.isfinite(d)]
    lo, hi = d[d <= threshold], d[d > threshold]
    if lo.size == 0 or hi.size == 0:
        return 0.0
    pooled = np.sqrt((mad_sigma(lo) ** 2 * lo.size + mad_sigma(hi) ** 2 * hi.size)
                     / d.size)
    gap = float(np.median(hi) - np.median(lo))
    return gap / float(pooled) if pooled > 0 else float("inf")


def reference_flows(points: Sequence[CyclePoint], healthy: Mask, slope: float, *,
                    window: float = 1.0, pool: Sequence[CyclePoint] | None = None) -> Arr:
    """Healthy flow [m³/s] at every cycle's oil temperature and pressure (module docstring, 2).

    The healthy cycles are those of ``points`` marked ``healthy``, or with ``pool`` (a
    baseline) those of ``pool`` marked ``healthy``.  NaN where no healthy cycle lies within
    ±``window`` [°C].
    """
    source = points if pool is None else pool
    th = np.array([c.theta for c in points])
    p = np.array([c.pressure for c in points])
    th_h = np.array([c.theta for c in source])
    q_h = np.array([c.flow for c in source])
    p_h = np.array([c.pressure for c in source])
    ok = np.asarray(healthy, dtype=bool)
    order = np.flatnonzero(ok)[np.argsort(th_h[ok])]
    ths = th_h[order]
    lo = np.searchsorted(ths, th - window, side="left")
    hi = np.searchsorted(ths, th + window, side="right")
    out = np.full(th.size, np.nan)
    for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
        if b > a:
            idx = order[a:b]
            out[i] = float(np.median(q_h[idx] + slope * (p[i] - p_h[idx])))
    return out


def _size(deficit: Arr, p: Arr, mu: Arr, leaking: Mask, lam: float) -> Arr:
    return np.asarray((deficit - lam * p / mu * leaking) / np.sqrt(p), dtype=np.float64)


def fit_shunt(deficit: Arr, p: Arr, mu: Arr, theta: Arr, use: Mask, *, steps: int = 400
              ) -> float:
    """Shunt ``λ`` [m³] that leaves the leak sizes of the ``use`` cycles uncorrelated with θ.

    A grid search (the rank correlation is piecewise constant) over ``0 … min(Δq·μ/Δp)``:
    the shunt cannot carry more than a cycle's whole deficit.

    Raises
    ------
    InputError
        Fewer than 10 cycles to fit on (``field="use"``).
    """
    sel = np.asarray(use, dtype=bool) & np.isfinite(deficit)
    if int(sel.sum()) < 10:
        raise InputError("the shunt needs at least 10 leaking cycles", field="use")
    x = p[sel] / mu[sel]
    top = float(np.min(deficit[sel] / x))
    if top <= 0:
        return 0.0
    grid = np.linspace(0.0, top, steps + 1)
    ones = np.ones(int(sel.sum()), dtype=bool)
    rho = [abs(float(spearmanr(_size(deficit[sel], p[sel], mu[sel], ones, lam),
                               theta[sel])[0])) for lam in grid]
    return float(grid[int(np.argmin(rho))])


@dataclass(frozen=True)
class ShuntEstimate:
    """Leak sizes of a campaign and the nuisance values found without labels.

    Attributes
    ----------
    size
        Orifice leak size ``K`` per cycle [m³/(s·Pa^½)] (≈ 0 for a healthy pump).
    deficit
        ``q_ref(θ, p) − q`` per cycle [m³/s].
    leaking
        Cycles above the leak threshold [-].
    threshold
        Deficit separating leaking cycles [m³/s]: of the first pass without a baseline,
        ``BASELINE_Z`` robust σ above the baseline's with one.
    slope
        Healthy ``dq/dp`` [m³/(s·Pa)].
    shunt
        ``λ`` of the laminar shunt [m³]; its flow at ``Δp``, ``μ`` is ``λ·Δp/μ``.
    reference
        ``"batch"`` (the leak beyond the batch's lower group) or ``"baseline"`` [-].
    separation
        The split's separation [robust σ] without a baseline; NaN with one.
    notes
        What the estimate could not do: cycles a baseline does not cover (their size NaN,
        not judged).
    """

    size: Arr
    deficit: Arr
    leaking: Mask
    threshold: float
    slope: float
    shunt: float
    reference: str = "batch"
    separation: float = float("nan")
    notes: tuple[str, ...] = ()


def shunt_estimates(records: Sequence[SeriesRecord], points: Sequence[CyclePoint], mu: Arr,
                    *, fit_on: Mask | None = None, window: float = 1.0,
                    leaking: Mask | None = None, shunt: float | None = None,
                    slope: float | None = None, baseline: HealthyBaseline | None = None
                    ) -> ShuntEstimate:
    """Leak size per cycle (module docstring, steps 1-3) from records and their cycle points.

    Parameters
    ----------
    records, points
        The cycles and their plateau means (:func:`~diagnostics.real.leakage.cycle_point`).
    mu
        Dynamic viscosity of the oil at each cycle's temperature [Pa·s].
    fit_on
        Cycles allowed to fit the slope and the shunt (e.g. those that ran the whole load
        program); all when None.  Never labels.
    window
        Half-width [°C] of the oil-temperature neighbourhood of the reference.
    leaking, shunt, slope
        Leaking cycles, ``λ`` [m³] and healthy ``dq/dp`` [m³/(s·Pa)] to use as given
        (e.g. found on other plateaus of the same cycles) instead of finding them here.
    baseline
        Cycles known healthy to read the batch against (module docstring, "What K is
        relative to"; give ``shunt`` with it for sizes that do not depend on the batch);
        without one the healthy cycles are the batch's lower group.

    Raises
    ------
    InputError
        Records and points differ in number; too few cycles (see the helpers); without a
        baseline (and without ``leaking`` given), a batch whose deficits show no separate
        leaking group (``field="baseline"``).
    """
    if len(records) != len(points) or len(mu) != len(points):
        raise InputError("records, points and viscosities differ in number", field="points")
    if baseline is not None:
        return _against_baseline(records, points, mu, baseline, fit_on=fit_on, window=window,
                                 leaking=leaking, shunt=shunt, slope=slope)
    p = np.array([c.pressure for c in points])
    th = np.array([c.theta for c in points])
    first = leakage_estimates(points, window=window) * p
    thr = leak_threshold(first)
    split = separation(first, thr)
    q = np.array([c.flow for c in points])
    apart = float(np.median(first[first > thr]) - np.median(first[first <= thr])) / float(
        np.median(q)) if np.any(first > thr) and np.any(first <= thr) else 0.0
    if leaking is None and (split < MIN_SEPARATION or apart < MIN_LEAK_FRACTION):
        raise InputError(
            f"the batch's flow deficits show no separate leaking group (its two sides "
            f"{split:.2f} robust σ and {100 * apart:.2f} % of the flow apart; at least "
            f"{MIN_SEPARATION:g} σ and {100 * MIN_LEAK_FRACTION:g} % needed): a batch of one "
            "class of cycles — all healthy, or all leaking — cannot be its own healthy "
            "reference; give a baseline of cycles known healthy (HealthyBaseline)",
            field="baseline")
    leak = first > thr if leaking is None else np.asarray(leaking, dtype=bool)
    use = np.ones(len(points), dtype=bool) if fit_on is None else np.asarray(fit_on, dtype=bool)
    if slope is None:
        slope = _median_slope(records, ~leak & use)
    deficit = reference_flows(points, ~leak, slope, window=window) - q
    m = np.asarray(mu, dtype=np.float64)
    lam = fit_shunt(deficit, p, m, th, leak & use) if shunt is None else float(shunt)
    size = _size(deficit, p, m, leak, lam)
    return ShuntEstimate(size, deficit, leak, thr, slope, lam, "batch", split)


def _median_slope(records: Sequence[SeriesRecord], use: Mask) -> float:
    slopes = np.array([plateau_slope(r) for r in records])
    ok = np.asarray(use, dtype=bool) & np.isfinite(slopes)
    return float(np.median(slopes[ok])) if ok.any() else 0.0


def _against_baseline(records: Sequence[SeriesRecord], points: Sequence[CyclePoint], mu: Arr,
                      baseline: HealthyBaseline, *, fit_on: Mask | None, window: float,
                      leaking: Mask | None, shunt: float | None, slope: float | None
                      ) -> ShuntEstimate:
    """:func:`shunt_estimates` read against ``baseline``: the reference flows and the slope
    from its cycles, a cycle leaking ``BASELINE_Z`` robust σ above its deficits."""
    if len(baseline.points) < 10 or len(baseline.records) != len(baseline.points):
        raise InputError("a baseline needs at least 10 healthy cycles, records and points "
                         "alike", field="baseline")
    every = np.ones(len(baseline.points), dtype=bool)
    if slope is None:
        slope = _median_slope(baseline.records, every)
    own = reference_flows(baseline.points, every, slope, window=window) - np.array(
        [c.flow for c in baseline.points])
    own = own[np.isfinite(own)]
    # at least the practical size: a baseline of few cycles (pairs at one temperature) can
    # state a scatter of 1e-7 l/min
    flow = float(np.median([c.flow for c in baseline.points]))
    thr = float(np.median(own) + max(BASELINE_Z * mad_sigma(own), MIN_LEAK_FRACTION * flow))
    p = np.array([c.pressure for c in points])
    th = np.array([c.theta for c in points])
    q = np.array([c.flow for c in points])
    deficit = reference_flows(points, every, slope, window=window, pool=baseline.points) - q
    uncovered = ~np.isfinite(deficit)
    notes: tuple[str, ...] = ()
    if uncovered.any():  # read "not leaking" with a NaN size, without a word (an analyst's pass)
        have = np.array([c.theta for c in baseline.points])
        said = (f"{int(uncovered.sum())} of {len(points)} cycles ({th[uncovered].min():.4g} to "
                f"{th[uncovered].max():.4g} °C) have no baseline cycle within ±{window:g} °C "
                f"of their oil temperature (the baseline's cycles: {have.min():.4g} to "
                f"{have.max():.4g} °C)")
        if uncovered.all():
            raise InputError(f"{said}: give a baseline that covers them, or read the batch "
                             "without a baseline", field="baseline")
        notes = (f"{said}: their size is NaN and they are not judged (leaking False there "
                 "means not judged); a baseline that covers them judges them",)
    leak = deficit > thr if leaking is None else np.asarray(leaking, dtype=bool)
    use = np.ones(len(points), dtype=bool) if fit_on is None else np.asarray(fit_on, dtype=bool)
    m = np.asarray(mu, dtype=np.float64)
    if shunt is not None:
        lam = float(shunt)
    else:  # no leaking cycle: the shunt carries nothing here
        lam = fit_shunt(deficit, p, m, th, leak & use) if leak.any() else 0.0
    size = _size(deficit, p, m, leak, lam)
    return ShuntEstimate(size, deficit, leak, thr, slope, lam, "baseline", notes=notes)


def fit_relaxation(records: Sequence[SeriesRecord], mu_of: Callable[[Arr], Arr], *,
                   taus: Sequence[float] = tuple(np.arange(0.0, 8.01, 0.5)),
                   fit_on: Mask | None = None) -> tuple[float, Arr]:
    """Relaxation time ``τ`` [s] of the accumulator's gas that makes the leak size plateau-free.

    Label-free: a cycle's leak size must not depend on which plateau measured it.  For each
    ``τ`` the leak size ``K`` from the cycle's plateaus up to its first relief episode and
    ``K₁`` from its first working plateau alone (the one every cycle has) are computed with the
    same leaking cycles, slope and ``λ``; ``τ`` is the grid value where ``K₁ − K`` of the
    leaking ``fit_on`` cycles carries the least rank correlation with the oil temperature
    (the gas relaxes faster when hot, so a wrong ``τ`` leaves a temperature trend between
    the plateaus).  Returns ``τ`` and the |ρ| of every grid value.

    Parameters
    ----------
    records
        The cycles of a campaign.
    mu_of
        Viscosity [Pa·s] at oil temperatures [°C].
    taus
        Grid of relaxation times [s].
    fit_on
        Cycles that count (e.g. those that ran the whole load program); all when None.

    Raises
    ------
    InputError
        An empty grid, or too few cycles (see :func:`shunt_estimates`).
    """
    if len(taus) == 0:
        raise InputError("the grid of relaxation times is empty", field="taus")
    use = (np.ones(len(records), dtype=bool) if fit_on is None
           else np.asarray(fit_on, dtype=bool))
    rho = np.full(len(taus), np.nan)
    for i, tau in enumerate(taus):
        pts = [cycle_point(r, stop_at_relief=True, relaxation=float(tau)) for r in records]
        one = [cycle_point(r, max_plateaus=1, relaxation=float(tau)) for r in records]
        th = np.array([c.theta for c in pts])
        est = shunt_estimates(records, pts, mu_of(th), fit_on=use)
        th1 = np.array([c.theta for c in one])
        est1 = shunt_estimates(records, one, mu_of(th1), leaking=est.leaking,
                               shunt=est.shunt, slope=est.slope)
        m = est.leaking & use & np.isfinite(est.size) & np.isfinite(est1.size)
        if int(m.sum()) >= 10:
            rho[i] = abs(float(spearmanr(est1.size[m] - est.size[m], th[m])[0]))
    if not np.any(np.isfinite(rho)):
        raise InputError("too few leaking cycles to find the relaxation time", field="records")
    return float(taus[int(np.nanargmin(rho))]), rho
