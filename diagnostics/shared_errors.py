"""Instrument errors that a joint visit's records share, in the spread of an estimate.

Each record's covariance (:mod:`diagnostics.record_model`) holds its readings' stated
uncertainties and those of its stated load and oil temperature; the records of a joint
diagnosis are otherwise independent.  An instrument's calibration error is not: the same
pressure transducer, flowmeter, load cell or thermometer is off by the same amount in every
record of a visit that it reads, so the records' errors do not average out.  A record that
states ``calibration_share`` f (:class:`~diagnostics.measurement.MeasurementRecord`) says
that the share f of each of its stated variances is such a calibration error:

.. math:: e_{k,c} = \\sqrt{f_k}\\,u_{k,c}\\,b_c + \\sqrt{1 - f_k}\\,u_{k,c}\\,ε_{k,c}

with ``b_c`` one standard normal per instrument for the visit and ``ε`` one per reading
(the correlation that one instrument or standard used for several input estimates brings,
GUM, JCGM 100:2008 §5.2 and F.1.2.3);
a record's own covariance is unchanged (f·u² + (1 − f)·u² = u²) and two records k ≠ k'
gain the covariance ``√(f_k f_k')·u_{k,c}·u_{k',c}`` between their readings of one
instrument.  The instrument of a reading is its quantity (``P1``, ``Q_B``, … one meter per
quantity on a visit; a velocity ratio counts as one instrument of its own), of a stated
condition its kind (the thermometer, the load cell, the pump's tachometer: each stated
condition's term ``s·u`` of :func:`diagnostics.record_model.condition_terms`).  The model's
own uncertainty ρ·ŷ stays independent.

The intervals of the fitted parameters are sandwiches ``A⁻¹ B A⁻¹`` of the estimator the
fit used, ``B = Σ_k G_kᵀ C_k G_k`` with ``G_k = C_h⁻¹ J_k`` the weights the fit gave record
k's readings (:func:`diagnostics.condition_interval.condition_sigmas`,
:func:`diagnostics.evidence_at_fit.pair_at_fit`).  The shared errors add the cross-record
blocks ``Σ_{k≠k'} G_kᵀ C_{kk'} G_k'``; per instrument, with ``a_k = √f_k·(its error's
reading-space vector)ᵀ·G_k``, that is ``(Σ_k a_k)ᵀ(Σ_k a_k) − Σ_k a_kᵀ a_k``
(:func:`shared_spread`): zero for one record, and for K identical records with f = 1
and no model term the spread of one record — K readings of one miscalibrated instrument
tell no more about its error than one (tested).

The ranking, its probabilities and the χ² tests still take the records as independent;
only the intervals (what the history keeps) count the shared part.  Commissioning
(:mod:`diagnostics.commissioning`), one least-squares fit of every record's readings at
once, whitens them with the visit's whole covariance instead (:func:`visit_covariance`):
its fit, intervals and χ² count the shared part exactly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from diagnostics.record_model import condition_kinds

if TYPE_CHECKING:
    from diagnostics.observations import RecordObservations
    from diagnostics.record_model import RecordModel

__all__ = ["shared_spread", "shares", "sharing", "visit_covariance"]

Arr = npt.NDArray[np.float64]


def shares(models: Sequence[RecordModel]) -> list[float]:
    """Each record's stated ``calibration_share`` [-]."""
    return [float(m.obs.record.calibration_share) for m in models]


def sharing(f: Sequence[float]) -> bool:
    """Whether records with shares ``f`` [-] share any error: at least two state one."""
    return sum(1 for x in f if x > 0.0) >= 2


def shared_spread(models: Sequence[RecordModel], weights: Sequence[Arr],
                  terms: Sequence[Sequence[Arr]]) -> Arr | None:
    """The cross-record blocks the shared calibration errors add to the sandwich's ``B``
    (module docstring), one ``(width, width)`` matrix per estimate [1/fitting
    coordinate²]; None where no two records share an instrument error (fewer than two
    records, or fewer than two that state a share).

    Parameters
    ----------
    models
        The records (their readings' names and uncertainties ``u`` [SI], their share).
    weights
        Per record, ``G_k`` of each estimate: ``(estimates, readings, width)`` [1/(SI ×
        fitting coordinate)]; 0 where the fit did not use a reading.
    terms
        Per record, its condition terms ``s·u`` at each estimate ``(estimates, readings)``
        [SI] in :func:`~diagnostics.record_model.condition_kinds` order (NaN where
        unknown: counted only where the weight is not 0).
    """
    f = shares(models)
    if not sharing(f):
        return None
    n_est, _, width = weights[0].shape
    total: dict[str, Arr] = {}
    own = np.zeros((n_est, width, width))
    for m, g, ts, share in zip(models, weights, terms, f, strict=True):
        if share <= 0.0:
            continue
        root = math.sqrt(share)
        parts = {f"reading {n}": root * m.obs.u[i] * g[:, i, :]
                 for i, n in enumerate(m.obs.names)}
        for kind, t in zip(condition_kinds(m.obs), ts, strict=True):
            with np.errstate(invalid="ignore"):
                used = np.where(g == 0.0, 0.0, t[:, :, None] * g)
            parts[f"condition {kind}"] = root * np.sum(used, axis=1)
        for key, a in parts.items():
            total[key] = total.get(key, 0.0) + a
            own += a[:, :, None] * a[:, None, :]
    cross = sum((a[:, :, None] * a[:, None, :] for a in total.values()),
                np.zeros((n_est, width, width)))
    return np.asarray(cross - own)


def visit_covariance(obs: Sequence[RecordObservations], diags: Sequence[Arr],
                     terms: Sequence[Sequence[Arr]]) -> tuple[Arr, list[Arr]] | None:
    """The covariance of a visit's stacked readings as ``diag(d) + Σ t tᵀ`` (the form
    :func:`diagnostics.evidence.whitening` factors): each record's independent variances
    less the shared share of its readings' (``diag − f·u²``), its condition terms times
    √(1 − f), and one term per instrument the records share (module docstring); None
    where no two records state a share.

    Parameters
    ----------
    obs
        The records' observations (names, ``u`` [SI], the record's share).
    diags
        Per record, the independent variances of its readings (instrument and model) [SI²].
    terms
        Per record, its condition terms ``s·u`` [SI] in
        :func:`~diagnostics.record_model.condition_kinds` order.
    """
    f = [float(o.record.calibration_share) for o in obs]
    if not sharing(f):
        return None
    sizes = [len(o.names) for o in obs]
    starts = np.concatenate([[0], np.cumsum(sizes)])
    n = int(starts[-1])
    diag = np.concatenate([d - x * o.u**2 for d, o, x in zip(diags, obs, f, strict=True)])
    out: list[Arr] = []
    shared: dict[str, Arr] = {}
    for k, (o, ts, x) in enumerate(zip(obs, terms, f, strict=True)):
        block = slice(int(starts[k]), int(starts[k + 1]))
        for kind, t in zip(condition_kinds(o), ts, strict=True):
            own = np.zeros(n)
            own[block] = math.sqrt(1.0 - x) * t
            out.append(own)
            if x > 0.0:
                vec = shared.setdefault(f"condition {kind}", np.zeros(n))
                vec[block] = math.sqrt(x) * t
        if x > 0.0:
            for i, name in enumerate(o.names):
                vec = shared.setdefault(f"reading {name}", np.zeros(n))
                vec[int(starts[k]) + i] = math.sqrt(x) * o.u[i]
    return np.maximum(diag, 0.0), [*out, *shared.values()]
