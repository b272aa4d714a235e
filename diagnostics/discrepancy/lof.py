"""Lack-of-fit F-test against repeated conditions: is the misfit more than the scatter?

When the data repeat a condition (replicated steady test points, or several records of
the same cycle), the residual splits into *pure error* (the scatter of the repeats about
their own mean) and *lack of fit* (the means' distance from the model)
(Draper & Smith, *Applied Regression Analysis*, 3rd ed. 1998, §2.1; NIST/SEMATECH
e-Handbook §4.4.4.3)::

    SS_pe  = Σ_g Σ_i (e_gi − ē_g)²        df_pe  = N − G
    SS_lof = Σ_g n_g·ē_g²                 df_lof = G − p
    F = (SS_lof/df_lof) / (SS_pe/df_pe)   p-value from F(df_lof, df_pe)

``e`` is the residual (measurement − model) of a model with ``p`` parameters fitted to the
same data; ``p = 0`` for a model that was not fitted to them (the stored rig).  Only groups
with at least two members carry pure error; groups of one still count in ``SS_lof``.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy import stats

from diagnostics.discrepancy.gap import aligned_residuals
from diagnostics.discrepancy.signals import condition_of
from diagnostics.discrepancy.simulate import simulate, timed_switch
from diagnostics.timeseries import SeriesRecord
from sim.rigs.assembly import Rig
from sim.rigs.schema import validate_rig_document

__all__ = ["LackOfFit", "lack_of_fit", "permutation_p", "repeats_lack_of_fit",
           "series_lack_of_fit"]


@dataclass(frozen=True)
class LackOfFit:
    """Outcome of :func:`lack_of_fit`.

    Attributes
    ----------
    f_stat
        The F statistic [-].
    p
        Its p-value [-] (small: the misfit is more than the scatter of the repeats).
    df_lof, df_pe
        Degrees of freedom of lack of fit and pure error [-].
    rms_lof
        RMS of the group means of the residual [unit of the residual].
    sigma_pe
        Pure-error standard deviation [unit of the residual].
    n_groups
        Number of conditions ``G`` [-].
    """

    f_stat: float
    p: float
    df_lof: int
    df_pe: int
    rms_lof: float
    sigma_pe: float
    n_groups: int

    @property
    def rms_excess(self) -> float:
        """The lack of fit's size beyond the scatter [unit of the residual].

        A group of ``n_g`` repeats whose mean is off by ``m_g`` has ``E[n_g·ē_g²] = σ² +
        n_g·m_g²``, so ``rms_lof²`` (``Σ n_g·ē_g²/N``) carries ``(G/N)·σ²`` of pure scatter
        even when the model is right; ``√max(0, rms_lof² − (G/N)·σ_pe²)`` is what remains,
        to compare with a practical size (noise alone gives ≈ 0, not ≈ σ/√n).
        """
        n = self.df_pe + self.n_groups  # N > 0: lack_of_fit returns None without repeats
        return math.sqrt(max(0.0, self.rms_lof ** 2 - self.n_groups / n * self.sigma_pe ** 2))

    def to_dict(self) -> dict[str, float]:
        """The test as JSON-able data."""
        return {"F": self.f_stat, "p": self.p, "df_lof": float(self.df_lof),
                "df_pe": float(self.df_pe), "rms_lof": self.rms_lof,
                "sigma_pe": self.sigma_pe, "rms_excess": self.rms_excess}


def lack_of_fit(residual: npt.ArrayLike, groups: Sequence[Hashable], n_params: int = 0
                ) -> LackOfFit | None:
    """The lack-of-fit F-test of ``residual`` against the repeats in ``groups`` (module
    docstring).

    Parameters
    ----------
    residual
        Residual per observation (measurement − model) [any unit].
    groups
        Condition label per observation; equal labels are repeats of one condition.
    n_params
        Parameters of the model fitted to these observations (0 for a stored model).

    Returns
    -------
    LackOfFit or None
        ``None`` when there are no repeats (no pure error) or no lack-of-fit degrees of
        freedom.
    """
    e = np.asarray(residual, dtype=float)
    if e.size != len(groups):
        raise ValueError("one group label per residual expected")
    labels: dict[Hashable, list[int]] = {}
    for i, g in enumerate(groups):
        labels.setdefault(g, []).append(i)
    ss_pe = ss_lof = 0.0
    for idx in labels.values():
        sub = e[idx]
        mean = float(np.mean(sub))
        ss_pe += float(np.sum((sub - mean) ** 2))
        ss_lof += len(idx) * mean * mean
    df_pe = e.size - len(labels)
    df_lof = len(labels) - n_params
    if df_pe <= 0 or df_lof <= 0 or ss_pe <= 0.0:
        return None
    F = (ss_lof / df_lof) / (ss_pe / df_pe)
    p = float(stats.f.sf(F, df_lof, df_pe))
    return LackOfFit(float(F), p, df_lof, df_pe, math.sqrt(ss_lof / e.size),
                     math.sqrt(ss_pe / df_pe), len(labels))


def permutation_p(residual: npt.ArrayLike, groups: Sequence[Hashable], *,
                  permutations: int = 999, seed: int = 0) -> float:
    """The lack-of-fit test's p-value by permutation, for noise that is not Gaussian.

    Under the null (the model right, the errors exchangeable) any assignment of the
    residuals to the rows is as likely as the observed one; ``Σe²`` does not change under
    a permutation, so ``F`` grows with ``SS_lof = Σ_g (Σ_{i∈g} e_i)²/n_g`` alone, and the
    p-value is the share of permutations whose ``SS_lof`` reaches the observed one
    (Good, *Permutation, Parametric and Bootstrap Tests of Hypotheses*, 3rd ed. 2005,
    §3.1).  Heavy-tailed scatter (t₃) makes the F-test's p-values too small; this one is
    exact under exchangeability.  ``(1 + hits)/(1 + permutations)``, so never below
    ``1/(1 + permutations)``.
    """
    e = np.asarray(residual, dtype=float)
    code: dict[Hashable, int] = {}
    idx = np.array([code.setdefault(g, len(code)) for g in groups], dtype=np.int64)
    if idx.size != e.size:
        raise ValueError("one group label per residual expected")
    counts = np.bincount(idx).astype(float)

    def ss_lof(x: npt.NDArray[np.float64]) -> float:
        return float(np.sum(np.bincount(idx, weights=x, minlength=counts.size) ** 2 / counts))

    observed = ss_lof(e) * (1.0 - 1e-12)
    rng = np.random.default_rng(seed)
    hits = sum(ss_lof(rng.permutation(e)) >= observed for _ in range(permutations))
    return (1.0 + hits) / (1.0 + permutations)


def series_lack_of_fit(records: Sequence[SeriesRecord], tables: Sequence[pd.DataFrame],
                       channels: Sequence[str], sigma: Mapping[str, float],
                       keys: Sequence[Hashable], *, every: float = 0.02) -> LackOfFit | None:
    """Lack of fit of simulated cycles against records that repeat a condition.

    Each record's residual (model − measurement, in units of the channel's noise σ) is
    sampled every ``every`` seconds of the steady part (10-90 %) of each phase; a group is
    (condition key, channel, phase, sample index), so the repeats of a condition give the
    pure error at each instant and the model (not fitted to these samples: ``n_params =
    0``) the lack of fit.

    Parameters
    ----------
    records, tables
        Measured records and the model's table for each.
    channels
        Channels compared.
    sigma
        Noise σ per channel [SI].
    keys
        Condition key of each record; equal keys are repeats.
    every
        Sampling interval of the residual [s] (longer than the noise's correlation).
    """
    if len(set(keys)) == len(keys):
        return None
    resid: list[float] = []
    groups: list[Hashable] = []
    for rec, table, key in zip(records, tables, keys, strict=True):
        res = aligned_residuals(rec, table, channels)
        for c in channels:
            for phase, (t, e, _) in res[c].items():
                if t.size < 3:
                    continue
                k = np.round(t / every).astype(int)
                keep = (t >= 0.1 * t[-1]) & (t <= 0.9 * t[-1])
                _, first = np.unique(k[keep], return_index=True)
                idx = np.flatnonzero(keep)[first]
                resid.extend((e[idx] / sigma[c]).tolist())
                groups.extend((key, c, phase, int(kk)) for kk in k[idx])
    counts: dict[Hashable, int] = {}
    for g in groups:
        counts[g] = counts.get(g, 0) + 1
    sel = [i for i, g in enumerate(groups) if counts[g] >= 2]
    if not sel:
        return None
    return lack_of_fit(np.asarray(resid)[sel], [groups[i] for i in sel], 0)


def repeats_lack_of_fit(records: Sequence[SeriesRecord], rig: Rig,
                         new_doc: dict[str, Any] | None, channels: Sequence[str],
                         sig: Mapping[str, float]) -> dict[str, Any]:
    """Lack-of-fit F-test of the stored (and augmented) rig against records that repeat a
    condition (:func:`~diagnostics.discrepancy.lof.series_lack_of_fit`); empty without
    repeats.  One simulation per distinct condition."""
    conds = [condition_of(r, rig) for r in records]
    switches = [timed_switch(r, rig) for r in records]
    keys = [(c.load, c.back_pressure, c.oil_temperature, c.pump_speed,
             None if sw is None else round(sw, 2)) for c, sw in zip(conds, switches, strict=True)]
    if len(set(keys)) == len(keys):
        return {}
    out: dict[str, Any] = {}
    rigs = {"before": rig}
    if new_doc is not None:
        rigs["after"] = Rig.from_spec(validate_rig_document(new_doc))
    for label, model in rigs.items():
        sims: dict[Any, pd.DataFrame] = {}
        for k, c, sw in zip(keys, conds, switches, strict=True):
            if k not in sims:
                sims[k] = simulate(model, c, None, sw)
        res = series_lack_of_fit(records, [sims[k] for k in keys], channels, sig, keys)
        out[label] = res.to_dict() if res is not None else None
    return out
