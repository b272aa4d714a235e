"""Hypothesis fits of the fast path: one compiled call per fit.

:func:`pair_problem` packs what the compiled :func:`~diagnostics.fastpath.kernel.pair_fit`
and :func:`~diagnostics.fastpath.kernel.profile_points` need — per record its condition's
parameter vectors and Newton states (:class:`~diagnostics.fastpath.maps.Context`), its
readings, their marginal σ and whitening matrix (the likelihood of
:class:`~diagnostics.record_model.RecordModel`) and observable indices — and
:class:`PairProblem` calls them.  What comes back
are numbers (the estimate, χ², the Jacobian, the predictions; the profile's χ² and
curvatures); the evidences are computed from them by the ranking's own functions
(:func:`diagnostics.ranking.laplace_evidence`, :func:`diagnostics.ranking.profile_evidence`).
:meth:`RecordPack.single` does the same for a one-parameter hypothesis on the maps
(:mod:`diagnostics.fastpath.singles`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from diagnostics.fastpath.maps import FastMaps, transform
from diagnostics.hypotheses import FaultParameter
from diagnostics.signatures import GRAPH_PARAMETERS
from sim.rigs import Rig

if TYPE_CHECKING:
    from diagnostics.record_model import RecordModel

__all__ = ["PairProblem", "RecordPack", "SingleNumbers", "pair_problem", "record_pack"]

Arr = npt.NDArray[np.float64]


@dataclass
class PairProblem:
    """A pair fit's arrays for the kernels (see :func:`pair_problem`)."""

    kernels: Any
    prob: tuple[Any, ...]
    masked: float
    n_records: int
    n_obs: int
    contexts: list[Any]

    def _store(self) -> None:
        """Keep the continuation states and chord Jacobians for the next fit at these
        conditions."""
        states, jac, piv, valid = self.prob[1], self.prob[17], self.prob[18], self.prob[19]
        hjac, hpiv, hvalid = self.prob[20], self.prob[21], self.prob[22]
        for k, ctx in enumerate(self.contexts):
            ctx.states[0:2] = states[k, 0:2]
            ctx.jac[:] = jac[k]
            ctx.piv[:] = piv[k]
            ctx.jac_valid[:] = valid[k]
            ctx.hjac[:] = hjac[k]
            ctx.hpiv[:] = hpiv[k]
            ctx.hjac_valid[:] = hvalid[k]

    def fit(self, z0: Arr, zl: Arr, zu: Arr) -> tuple[Arr, float, Arr, list[Arr]]:
        """Levenberg-Marquardt from ``z0``: ``(z, χ², last Jacobian, predictions per
        record)`` (:func:`~diagnostics.fastpath.kernel.pair_fit`)."""
        jac = np.zeros((self.n_obs, 2))
        r = np.empty(self.n_obs)
        fulls = np.empty((self.n_records, 9))
        z, cost = self.kernels.pair_fit(np.asarray(z0, dtype=np.float64), zl, zu, self.prob,
                                        self.masked, jac, r, fulls)
        self._store()
        return np.asarray(z), float(cost), jac, list(fulls)

    def profile(self, z_hat: Arr, slope: float, weak: int, grid: Arr, zl: Arr, zu: Arr
                ) -> tuple[Arr, Arr, Arr]:
        """χ², curvature and strong coordinate along the weak axis
        (:func:`~diagnostics.fastpath.kernel.profile_points`)."""
        n = grid.size
        chi2, hss, zs = np.empty(n), np.empty(n), np.empty(n)
        self.kernels.profile_points(np.asarray(z_hat, dtype=np.float64), slope, weak, grid, zl,
                                    zu, self.prob, self.masked, chi2, hss, zs)
        self._store()
        return chi2, hss, zs


@dataclass
class RecordPack:
    """The records of a ranking in the kernels' arrays (built once per ranking; the Newton
    states carry over from one pair fit to the next, as the direct evaluator's do, and so do
    the chord Jacobians of the moving and the held state)."""

    contexts: list[Any]
    ctx_p: Arr
    ctx_i: Arr
    base: Arr
    yobs: Arr
    sig: Arr
    wrow: Arr
    oidx: npt.NDArray[np.int64]
    start: npt.NDArray[np.int64]
    jac: Arr
    piv: npt.NDArray[np.int64]
    jac_valid: npt.NDArray[np.bool_]
    hjac: Arr
    hpiv: npt.NDArray[np.int64]
    hjac_valid: npt.NDArray[np.bool_]
    nominal: Arr
    models: Sequence[RecordModel]

    def single(self, name: str, tie: float) -> SingleNumbers:
        """The numbers of the one-parameter hypothesis ``name`` on the records' maps
        (:func:`~diagnostics.fastpath.singles.single_scan`, one compiled call)."""
        maps = [m.maps.maps[name].pred for m in self.models]
        preds = maps[0][None] if len(maps) == 1 else np.ascontiguousarray(np.stack(maps))
        z = self.models[0].maps.maps[name].axes[0]
        chi2 = np.empty(z.size)
        top, log_ev, k, zk, lo, hi, det = self.contexts[0].kernels.single_scan(
            z, preds, self.nominal, self.yobs, self.wrow, self.sig, self.oidx, self.start,
            tie, chi2)
        return SingleNumbers(float(top), float(log_ev), int(k), float(chi2[k]), float(zk),
                             float(lo), float(hi), float(det), z)


@dataclass
class SingleNumbers:
    """A one-parameter fit's numbers (:meth:`RecordPack.single`): the maximum of the
    log-likelihood ``top`` (−∞: no point predicts the readings), ``log_evidence``, the
    estimate's map index ``k`` and χ² there, the estimate and 95 % interval in fitting
    coordinates, the detectability [σ] and the map's axis ``z``."""

    top: float
    log_evidence: float
    k: int
    chi2: float
    z_hat: float
    z_low: float
    z_high: float
    detectability: float
    z: Arr


def record_pack(rig: Rig, models: Sequence[RecordModel]) -> RecordPack | None:
    """:class:`RecordPack` of ``models`` (None unless every record has fast maps)."""
    maps = [m.maps for m in models]
    ctxs = [mp.ctx for mp in maps if isinstance(mp, FastMaps)]
    if len(ctxs) != len(maps):
        return None
    return RecordPack(
        ctxs, np.ascontiguousarray(np.array([c.params for c in ctxs])),
        np.ascontiguousarray(np.array([c.states for c in ctxs])),
        np.array([rig.base[n] for n in GRAPH_PARAMETERS]),
        np.concatenate([m.obs.values for m in models]).astype(np.float64),
        np.concatenate([m.sigma for m in models]).astype(np.float64),
        _white_rows(models),
        np.concatenate([m.idx for m in models]).astype(np.int64),
        np.cumsum([0, *(len(m.idx) for m in models)]).astype(np.int64),
        np.array([c.jac for c in ctxs]), np.array([c.piv for c in ctxs]),
        np.array([c.jac_valid for c in ctxs]), np.array([c.hjac for c in ctxs]),
        np.array([c.hpiv for c in ctxs]), np.array([c.hjac_valid for c in ctxs]),
        np.ascontiguousarray(np.array([m.maps.nominal for m in models])), models)


def _white_rows(models: Sequence[RecordModel]) -> Arr:
    """Each record's whitening matrix W stacked by rows: row ``a`` (reading ``a`` of all
    records) holds the row of W of its record over that record's readings, zero-padded."""
    width = max(len(m.idx) for m in models)
    rows = np.zeros((sum(len(m.idx) for m in models), width))
    a = 0
    for m in models:
        n = len(m.idx)
        rows[a:a + n, :n] = m.white
        a += n
    return np.ascontiguousarray(rows)


def pair_problem(rig: Rig, pack: RecordPack, params: tuple[FaultParameter, ...],
                 masked: float) -> PairProblem | None:
    """The compiled problem of fitting ``params`` to the records of ``pack``, or None when
    a parameter's mapping is not one the kernels know (the caller then fits directly)."""
    trs = [transform(rig, p) for p in params]
    if len(params) != 2 or any(t is None for t in trs):
        return None
    ts = [t for t in trs if t is not None]
    which = np.array([t.index for t in ts], dtype=np.int64)
    tlog = np.array([t.log for t in ts], dtype=np.bool_)
    tmode = np.array([t.mode for t in ts], dtype=np.int64)
    tconst = np.array([t.const for t in ts], dtype=np.float64)
    c0 = pack.contexts[0]
    prob = (pack.ctx_p, pack.ctx_i, c0.mask, c0.scale, c0.oi, pack.base, c0.gidx, which, tlog,
            tmode, tconst, pack.yobs, pack.sig, pack.wrow, pack.oidx, pack.start, c0.nout,
            pack.jac, pack.piv, pack.jac_valid, pack.hjac, pack.hpiv, pack.hjac_valid)
    return PairProblem(c0.kernels, prob, float(masked), len(pack.contexts),
                       int(pack.yobs.size), pack.contexts)
