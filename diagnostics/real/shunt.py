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
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError

__all__ = ["ShuntEstimate", "fit_relaxation", "fit_shunt", "leak_threshold", "plateau_slope",
           "reference_flows", "shunt_estimates"]

Arr = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]


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


def reference_flows(points: Sequence[CyclePoint], healthy: Mask, slope: float, *,
                    window: float = 1.0) -> Arr:
    """Healthy flow [m³/s] at every cycle's oil temperature and pressure (module docstring, 2).

    NaN where no healthy cycle lies within ±``window`` [°C].
    """
    th = np.array([c.theta for c in points])
    q = np.array([c.flow for c in points])
    p = np.array([c.pressure for c in points])
    ok = np.asarray(healthy, dtype=bool)
    order = np.flatnonzero(ok)[np.argsort(th[ok])]
    ths = th[order]
    lo = np.searchsorted(ths, th - window, side="left")
    hi = np.searchsorted(ths, th + window, side="right")
    out = np.full(th.size, np.nan)
    for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
        if b > a:
            idx = order[a:b]
            out[i] = float(np.median(q[idx] + slope * (p[i] - p[idx])))
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
        First-pass deficit separating leaking cycles [m³/s].
    slope
        Healthy ``dq/dp`` [m³/(s·Pa)].
    shunt
        ``λ`` of the laminar shunt [m³]; its flow at ``Δp``, ``μ`` is ``λ·Δp/μ``.
    """

    size: Arr
    deficit: Arr
    leaking: Mask
    threshold: float
    slope: float
    shunt: float


def shunt_estimates(records: Sequence[SeriesRecord], points: Sequence[CyclePoint], mu: Arr,
                    *, fit_on: Mask | None = None, window: float = 1.0,
                    leaking: Mask | None = None, shunt: float | None = None,
                    slope: float | None = None) -> ShuntEstimate:
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

    Raises
    ------
    InputError
        Records and points differ in number, or too few cycles (see the helpers).
    """
    if len(records) != len(points) or len(mu) != len(points):
        raise InputError("records, points and viscosities differ in number", field="points")
    p = np.array([c.pressure for c in points])
    th = np.array([c.theta for c in points])
    first = leakage_estimates(points, window=window) * p
    thr = leak_threshold(first)
    leak = first > thr if leaking is None else np.asarray(leaking, dtype=bool)
    use = np.ones(len(points), dtype=bool) if fit_on is None else np.asarray(fit_on, dtype=bool)
    if slope is None:
        slopes = np.array([plateau_slope(r) for r in records])
        ok = ~leak & use & np.isfinite(slopes)
        slope = float(np.median(slopes[ok])) if ok.any() else 0.0
    q = np.array([c.flow for c in points])
    deficit = reference_flows(points, ~leak, slope, window=window) - q
    m = np.asarray(mu, dtype=np.float64)
    lam = fit_shunt(deficit, p, m, th, leak & use) if shunt is None else float(shunt)
    size = _size(deficit, p, m, leak, lam)
    return ShuntEstimate(size, deficit, leak, thr, slope, lam)


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
