"""Leak size plateau by plateau: every plateau against the healthy flow of the *same* plateau.

The pooled leak size of :mod:`diagnostics.real.shunt` compares a cycle's plateaus, pooled,
with healthy cycles' pooled plateaus.  On the ZeMA rig that carries the cooler state into
the estimate over all cycles (``make real-data``): the 240 cycles that leave the load
program for the relief valve after their first one or two working plateaus are all in the
hottest cooler state, and the leak deficit of a leaking pump is not the same on every
plateau of the program — it grows through the cycle (median over the leaking cycles that
ran the whole program, relative to their own mean: about 0.97, 0.99, 1.03, 1.00, 1.00 on
the plateaus at 146, 156, 166, 156, 151 bar), so a cycle measured on its first plateaus
alone reads a smaller leak than one measured on all five.  This module compares like with
like, without labels:

1. **Plateau table** (:func:`plateau_table`): the settled flow
   (:func:`~diagnostics.real.relaxation.settled_flow`) and mean pressure of each working
   plateau, numbered in the order of the load program, up to the cycle's first departure to
   the relief valve.
2. **Deficit per plateau** (:func:`plateau_deficits`): the healthy cycles' flow on the same
   plateau number within ±``window`` °C, moved to the plateau's pressure with the healthy
   ``dq/dp``, minus the plateau's flow — same preceding step, same accumulator transient.
3. **Leak size per plateau**, orifice + laminar shunt as in :mod:`~diagnostics.real.shunt`
   (paper 000 eq. 6 for the shunt)::

       K_k = (Δq_k − λ·Δp_k/μ(θ)·[leaking]) / √Δp_k                     [m³/(s·Pa^½)]

4. **Plateau profile** (:func:`plateau_profile`): ``r_k`` = median over the leaking cycles
   that ran the whole program of ``K_k / mean_j K_j`` [-]; a cycle's leak size is the mean of
   ``K_k / r_k`` over the plateaus it has, i.e. the leak size of the whole program whichever
   plateaus measured it.  ``λ`` is found by the rule of
   :func:`~diagnostics.real.shunt.fit_shunt` (no rank correlation of the leaking
   whole-program cycles' sizes with θ), the profile refitted at every trial ``λ``.

Optionally (``precharge`` of :func:`plateau_table`) each plateau's flow first gets back the
oil the accumulator took in while the pressure still drifted on the plateau
(:func:`~diagnostics.real.precharge.stored_rate`, the cycle's own pre-charge and the rig's
accumulator volume from :mod:`~diagnostics.real.precharge`): ``q + d(V0 − V(p))/dt``.

Nothing here is fitted with labels; "leaking" is the label-free threshold of
:func:`~diagnostics.real.shunt.leak_threshold`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.stats import spearmanr

from diagnostics.pump.data import BenchData
from diagnostics.real.leakage import record_plateaus
from diagnostics.real.precharge import stored_rate
from diagnostics.real.relaxation import settled_flow
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError

__all__ = ["PlateauTable", "ProfileEstimate", "plateau_deficits", "plateau_profile",
           "plateau_table", "profile_sizes", "settled_bench", "stated_pump_speed"]

Arr = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class PlateauTable:
    """Working plateaus of a campaign, numbered in program order (NaN where a cycle has none).

    Attributes
    ----------
    pressure
        Plateau mean pressure [Pa], cycles × plateaus.
    flow
        Plateau settled flow [m³/s], cycles × plateaus.
    theta
        Oil temperature over the plateaus used [°C], per cycle.
    intake
        Mean accumulator intake given back to each plateau's flow [m³/s], cycles ×
        plateaus (None: no pre-charge given).
    """

    pressure: Arr
    flow: Arr
    theta: Arr
    intake: Arr | None = None

    @property
    def complete(self) -> Mask:
        """Cycles with every plateau of the table [-]."""
        return np.asarray(np.all(np.isfinite(self.flow), axis=1), dtype=np.bool_)

    def bench(self, speed: float, cycles: Mask | None = None, *,
              provenance: str = "") -> BenchData:
        """The plateaus of ``cycles`` (all if None) as a steady pump-bench table
        (:class:`~diagnostics.pump.data.BenchData`, one row per plateau with a flow): the
        plateau pressure over a tank inlet (``p_in`` = 0), the shaft ``speed`` [rad/s] (the
        rig's stated one where the data record none), the cycle's oil temperature and the
        plateau's flow; measured data (``simulated`` False).  What the discrepancy
        workflow's steady branch reads (:func:`diagnostics.discrepancy.steady.discover_steady`).

        Raises
        ------
        InputError
            ``cycles`` not one boolean per cycle, or no plateau with a flow among them
            (``field="cycles"``).
        """
        use = np.ones(self.theta.size, dtype=bool) if cycles is None else np.asarray(cycles)
        if use.shape != self.theta.shape or use.dtype != np.bool_:
            raise InputError(f"cycles must be {self.theta.size} booleans, one per cycle",
                             field="cycles")
        theta = np.broadcast_to(self.theta[:, None], self.flow.shape)
        ok = use[:, None] & np.isfinite(self.flow) & np.isfinite(self.pressure)
        if not ok.any():
            raise InputError("no plateau with a flow in these cycles", field="cycles")
        n = int(ok.sum())
        return BenchData(p_in=np.zeros(n), p_out=self.pressure[ok], omega=np.full(n, speed),
                         theta=theta[ok], q=self.flow[ok], simulated=False,
                         provenance=provenance)


def stated_pump_speed(values: Mapping[str, float], *, field: str = "rig_id") -> float:
    """The rig's stated pump shaft speed ``pump.speed`` [rad/s] from its parameter
    ``values`` — what a plateau table records as the bench speed, the data recording none;
    :class:`InputError` (``field``) when the rig states none."""
    if "pump.speed" not in values:
        raise InputError("the rig states no pump speed for the plateau table", field=field)
    return float(values["pump.speed"])


def settled_bench(records: Sequence[SeriesRecord], speed: float, *, relaxation: float,
                  provenance: str = "") -> BenchData:
    """The records' settled working plateaus as a steady pump-bench table: one row per
    plateau (:func:`plateau_table` with ``relaxation`` [s], :meth:`PlateauTable.bench` at
    the shaft ``speed`` [rad/s]) — what ``hydrodiag import zema --bench`` writes and the
    discrepancy workflow checks for a rig without a working/return cycle."""
    return plateau_table(records, relaxation=relaxation).bench(speed, provenance=provenance)


def plateau_table(records: Sequence[SeriesRecord], *, plateaus: int = 5,
                  relaxation: float = 0.0, pressure: str = "p_pump", flow: str = "q_work",
                  temperature: str = "oil_temperature",
                  min_flow_fraction: float = 0.2, precharge: npt.ArrayLike | None = None,
                  gas_volume: float = 0.0, polytropic: float = 1.4) -> PlateauTable:
    """The first ``plateaus`` working plateaus of each record, up to its first relief episode.

    Working and no-flow plateaus as in :func:`~diagnostics.real.leakage.cycle_point`
    (``stop_at_relief=True``); ``relaxation`` [s] > 0 takes each plateau's settled flow.
    With ``precharge`` (per record, at the gas temperature [Pa]), ``gas_volume`` ``V0``
    [m³] and ``polytropic`` ``n`` [-], each flow sample first gets back the accumulator's
    intake (:func:`~diagnostics.real.precharge.stored_rate`).

    Raises
    ------
    InputError
        ``plateaus`` < 1, ``precharge`` not one finite value per record
        (``field="precharge"``), a record without a working plateau (``field=pressure``),
        or without its oil temperature, neither a channel nor a stated condition
        (``field=temperature``).
    """
    if plateaus < 1:
        raise InputError(f"plateaus must be ≥ 1, got {plateaus}", field="plateaus")
    n = len(records)
    pre = None if precharge is None else np.asarray(precharge, dtype=np.float64)
    if pre is not None and (pre.shape != (n,) or not np.all(np.isfinite(pre))):
        raise InputError("precharge needs one finite pre-charge per record", field="precharge")
    pm = np.full((n, plateaus), math.nan)
    qm = np.full((n, plateaus), math.nan)
    th = np.full(n, math.nan)
    im = None if pre is None else np.full((n, plateaus), math.nan)
    for i, r in enumerate(records):
        p, q = r.channel(pressure), r.channel(flow)
        if temperature in r.channels:
            temp = r.channel(temperature)
        elif math.isfinite(r.condition.get("oil_temperature", math.nan)):
            temp = np.full(p.size, r.condition["oil_temperature"])
        else:  # it was a NaN that the bench table refused as "theta: row 0"
            raise InputError(f"record {r.name!r} has no channel {temperature!r} and states no "
                             "oil temperature (a constant 'oil_temperature [degC]' column): "
                             "the plateaus need the oil temperature", field=temperature)
        means = [(a, b, float(q[a:b].mean())) for a, b in record_plateaus(r, pressure=pressure)]
        top = max((m for *_, m in means), default=0.0)
        kept: list[tuple[int, int]] = []
        for a, b, m in means:
            if top > 0 and m >= min_flow_fraction * top:
                kept.append((a, b))
            elif kept:
                break
        if not kept:
            raise InputError(f"record {r.name!r} has no pressure plateau with flow",
                             field=pressure)
        kept = kept[:plateaus]
        rate = r.sample_rate or 1.0
        for k, (a, b) in enumerate(kept):
            pm[i, k] = float(p[a:b].mean())
            qk = q[a:b]
            if pre is not None and im is not None:
                intake = stored_rate(p[a:b], float(pre[i]), gas_volume, rate, polytropic)
                im[i, k] = float(intake.mean())
                qk = qk + intake
            qm[i, k] = settled_flow(qk, relaxation * rate)
        th[i] = float(np.concatenate([temp[a:b] for a, b in kept]).mean())
    return PlateauTable(pm, qm, th, im)


def plateau_deficits(table: PlateauTable, healthy: Mask, slope: float, *,
                     window: float = 1.0) -> Arr:
    """``Δq_k`` [m³/s]: healthy flow on the same plateau at the cycle's θ and pressure − flow.

    The healthy flow is the median over the ``healthy`` cycles within ±``window`` [°C] that
    have plateau k, each moved to the plateau's pressure with ``slope`` [m³/(s·Pa)]; NaN
    where none.
    """
    ok = np.asarray(healthy, dtype=bool)
    th = table.theta
    out = np.full(table.flow.shape, math.nan)
    for k in range(table.flow.shape[1]):
        have = ok & np.isfinite(table.flow[:, k])
        order = np.flatnonzero(have)[np.argsort(th[have])]
        ths = th[order]
        lo = np.searchsorted(ths, th - window, side="left")
        hi = np.searchsorted(ths, th + window, side="right")
        pk, qk = table.pressure[:, k], table.flow[:, k]
        for i in np.flatnonzero(np.isfinite(qk)):
            idx = order[lo[i]:hi[i]]
            if idx.size:
                out[i, k] = float(np.median(qk[idx] + slope * (pk[i] - pk[idx]))) - qk[i]
    return out


def _sizes(deficit: Arr, p: Arr, mu: Arr, leaking: Mask, lam: float) -> Arr:
    shunt = lam * p / mu[:, None] * np.asarray(leaking, dtype=np.float64)[:, None]
    return np.asarray((deficit - shunt) / np.sqrt(p), dtype=np.float64)


def plateau_profile(sizes: Arr, use: Mask) -> Arr:
    """``r_k`` [-]: median of ``K_k / mean_j K_j`` over the ``use`` cycles with every plateau.

    Raises
    ------
    InputError
        Fewer than 10 such cycles (``field="use"``).
    """
    sel = np.asarray(use, dtype=bool) & np.all(np.isfinite(sizes), axis=1)
    if int(sel.sum()) < 10:
        raise InputError("the plateau profile needs at least 10 leaking cycles with every "
                         "plateau", field="use")
    k = sizes[sel]
    return np.asarray(np.median(k / k.mean(axis=1, keepdims=True), axis=0), dtype=np.float64)


@dataclass(frozen=True)
class ProfileEstimate:
    """Leak sizes from the plateau table and the nuisance values found without labels.

    Attributes
    ----------
    size
        Leak size of the whole program per cycle [m³/(s·Pa^½)] (mean of ``K_k/r_k``).
    per_plateau
        ``K_k`` per cycle and plateau [m³/(s·Pa^½)].
    profile
        ``r_k`` per plateau [-].
    shunt
        ``λ`` [m³].
    """

    size: Arr
    per_plateau: Arr
    profile: Arr
    shunt: float


def profile_sizes(deficit: Arr, pressure: Arr, mu: Arr, theta: Arr, leaking: Mask,
                  fit_on: Mask, *, shunt: float | None = None, steps: int = 200
                  ) -> ProfileEstimate:
    """Leak size per cycle (module docstring, steps 3-4) from the deficits per plateau.

    Parameters
    ----------
    deficit, pressure
        ``Δq_k`` [m³/s] and plateau pressures [Pa], cycles × plateaus.
    mu, theta
        Viscosity [Pa·s] and oil temperature [°C] per cycle.
    leaking
        Cycles above the leak threshold [-].
    fit_on
        Cycles allowed to fit ``λ`` and the profile (e.g. those that ran the whole program).
    shunt
        ``λ`` [m³] to use as given; else the grid value ``0 … min(Δq·μ/Δp)`` that leaves the
        sizes of the leaking ``fit_on`` cycles without rank correlation with θ.

    Raises
    ------
    InputError
        Shapes differ, or too few leaking cycles (``field="use"``).
    """
    d = np.asarray(deficit, dtype=np.float64)
    p = np.asarray(pressure, dtype=np.float64)
    m = np.asarray(mu, dtype=np.float64)
    if d.shape != p.shape or d.shape[0] != m.size or m.size != np.size(theta):
        raise InputError("deficits, pressures, viscosities and temperatures differ in shape",
                         field="deficit")
    leak = np.asarray(leaking, dtype=bool)
    use = leak & np.asarray(fit_on, dtype=bool) & np.all(np.isfinite(d), axis=1)
    if int(use.sum()) < 10:
        raise InputError("the plateau profile needs at least 10 leaking cycles", field="use")

    def size_at(lam: float) -> tuple[Arr, Arr, Arr]:
        per = _sizes(d, p, m, leak, lam)
        r = plateau_profile(per, use)
        with np.errstate(invalid="ignore"):
            return np.asarray(np.nanmean(per / r, axis=1), dtype=np.float64), per, r

    if shunt is None:
        top = float(np.min(np.nanmean(d[use], axis=1) * m[use] / np.nanmean(p[use], axis=1)))
        lam = 0.0
        if top > 0:
            grid = np.linspace(0.0, top, steps + 1)
            th = np.asarray(theta, dtype=np.float64)[use]
            rho = [abs(float(spearmanr(size_at(float(g))[0][use], th)[0])) for g in grid]
            lam = float(grid[int(np.argmin(rho))])
    else:
        lam = float(shunt)
    size, per, r = size_at(lam)
    return ProfileEstimate(size, per, r, lam)
