"""One record inside a ranking: its readings, their covariance, and its condition's
signature maps.

The covariance of the record's readings is

.. math:: C = \\mathrm{diag}(u_i^2 + (ρ\\,ŷ_i)^2) + \\sum_k s_k s_k^T u_k^2

with ``u`` the measurements' own uncertainties, ρ a relative model uncertainty and ``s_k``
the healthy readings' sensitivity to the record's oil temperature and load (one-sided
differences of 1 K and 1 % of the load), ``u_k`` their standard uncertainties: one
thermometer or load-cell error moves every reading of the record at once, so it is a
correlated (rank-one) term, not one independent σ per reading.  Residuals are whitened by
``W`` with ``WᵀW = C⁻¹`` (:func:`diagnostics.evidence.whitening`, GUM Supplement 2 §3.21);
``sigma`` is the marginal standard uncertainty of each reading (the diagonal of C).  This
is the one likelihood of both inference paths: the direct one
(:mod:`diagnostics.pair_direct`) calls :meth:`RecordModel.whitened`, the compiled one
(:mod:`diagnostics.fastpath.fits`) is handed ``white`` and multiplies by it in the kernel.

The healthy predictions come from the direct evaluator
(:func:`diagnostics.signatures.evaluator`) or, on the fast path, from the compiled kernels
(:func:`diagnostics.fastpath.maps.nominal_observables`); the maps likewise.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from diagnostics.evidence import whitening
from diagnostics.fastpath.maps import FastMaps, fast_maps, nominal_observables
from diagnostics.observations import RecordObservations, condition_sigma
from diagnostics.signatures import OBSERVABLES, SignatureMaps, evaluator, signature_maps
from sim.errors import MeasurementError, ParameterError, SimulationError
from sim.rigs import Condition, Rig

__all__ = ["RecordModel", "condition_kinds", "condition_moves", "condition_terms"]

Arr = npt.NDArray[np.float64]

#: cap of a condition sensitivity [unit of the reading per K or N] (its square stays finite)
_HUGE = 1.0e100


def condition_moves(obs: RecordObservations
                    ) -> list[tuple[float, list[tuple[Condition, float]]]]:
    """For each stated condition of ``obs`` that is uncertain: its standard uncertainty
    [K or N/Pa] and the moved conditions of a one-sided difference, with their steps
    (±1 K of oil temperature; ±1 % of the load, or of the back pressure of a rig without
    a load; ±1 % of a stated pump speed), in :func:`condition_kinds` order."""
    return [(u, moved) for _, u, moved in _labelled_moves(obs)]


def condition_kinds(obs: RecordObservations) -> list[str]:
    """The instrument of each of :func:`condition_moves` (``"oil_temperature"``,
    ``"load"``, ``"pump_speed"``): the thermometer, load cell or tachometer whose error a
    joint visit's records may share (:mod:`diagnostics.shared_errors`)."""
    return [kind for kind, _, _ in _labelled_moves(obs)]


def _labelled_moves(obs: RecordObservations
                    ) -> list[tuple[str, float, list[tuple[Condition, float]]]]:
    u_t, u_f, u_s = condition_sigma(obs.record)
    cond = obs.condition
    out: list[tuple[str, float, list[tuple[Condition, float]]]] = []
    if u_t > 0:
        out.append(("oil_temperature", u_t,
                    [(replace(cond, oil_temperature=cond.oil_temperature + s), s)
                     for s in (1.0, -1.0)]))
    if u_f > 0:
        if cond.load > 0:
            step = 0.01 * cond.load
            out.append(("load", u_f,
                        [(replace(cond, load=cond.load + s), s) for s in (step, -step)]))
        else:
            step = 0.01 * max(cond.back_pressure, 1e5)
            out.append(("load", u_f, [(replace(cond, back_pressure=cond.back_pressure + s), s)
                                      for s in (step, -step)]))
    if u_s > 0 and cond.pump_speed is not None and cond.pump_speed > 0:
        step = 0.01 * cond.pump_speed
        out.append(("pump_speed", u_s, [(replace(cond, pump_speed=cond.pump_speed + s), s)
                                        for s in (step, -step)]))
    return out


def condition_terms(pred: Arr, moves: list[tuple[float, list[tuple[Condition, float]]]],
                    readings_at: Callable[[Condition], Arr]) -> list[Arr]:
    """The correlated terms ``s_k·u_k`` of the module docstring: for each of ``moves``
    (:func:`condition_moves`), the sensitivity of the readings ``pred`` by a one-sided
    difference of ``readings_at`` (the other side where the first has no steady point,
    :class:`~sim.errors.SimulationError`, or lies past the circuit's range of conditions,
    :class:`~sim.errors.ParameterError`; 0 where neither), times the uncertainty."""
    terms = []
    for u, moved in moves:
        sens = np.zeros_like(pred)
        for cond, step in moved:
            try:
                moved_pred = readings_at(cond)
            except (SimulationError, ParameterError):  # no steady point, or past a bound
                continue
            with np.errstate(over="ignore", invalid="ignore"):
                d = (moved_pred - pred) / step
            # near a stall a reading (the velocity ratio) may react without bound: cap the
            # sensitivity so its σ stays finite, huge, and the reading weighs nothing
            sens = np.asarray(np.clip(np.where(np.isnan(d), 0.0, d), -_HUGE, _HUGE))
            break
        terms.append(sens * u)
    return terms


class RecordModel:
    """One record's observations, their covariance, and its condition's signature maps.

    Attributes ``sigma`` (marginal σ of each reading [SI]), ``white`` (whitening
    matrix W [1/SI], lower triangular, one row and column per reading), ``diag`` (the
    covariance's uncorrelated part, the readings' and the model's variances [SI²]) and
    ``log_det`` (ln |C| [-]).

    Parameters
    ----------
    rig
        The rig.
    obs
        The record's observations.
    model_rel
        Relative model uncertainty [-].
    fast
        Build maps and healthy predictions with the compiled kernels
        (:mod:`diagnostics.fastpath`) instead of the direct evaluator.
    """

    def __init__(self, rig: Rig, obs: RecordObservations, model_rel: float,
                 fast: bool = False) -> None:
        self.obs = obs
        self.fast = fast
        if fast:
            self.maps: SignatureMaps = fast_maps(rig, obs.condition)
            assert isinstance(self.maps, FastMaps)
            # the solvers start where they did after the maps were built, whatever ran at
            # this condition before: the same record gives the same answer
            self.maps.rewind()
        else:
            self.maps = signature_maps(rig, obs.condition)
            evaluator(rig, obs.condition).rewind()
        self.idx = np.array([OBSERVABLES.index(n) for n in obs.names], dtype=np.int64)
        pred = self.maps.nominal[self.idx]
        # a reading the healthy rig cannot produce (a stalled return stroke has no velocity
        # ratio) gets no model or condition term: its σ is the measurement's own
        rel = model_rel * pred
        #: the uncorrelated part of the covariance: the readings' own and the model's [SI²]
        self.diag = obs.u**2 + np.where(np.isnan(rel), 0.0, rel) ** 2
        terms = condition_terms(pred, condition_moves(obs),
                                lambda cond: self._moved(rig, cond))
        self.sigma, self.white = whitening(self.diag, terms)
        #: ln |C| of the readings' covariance, ``−2 Σ ln |W_ii|`` (W triangular) [-]
        self.log_det = -2.0 * float(np.sum(np.log(np.abs(np.diag(self.white)))))
        for name, value, sig in zip(obs.names, obs.values, self.sigma, strict=True):
            if not sig > 0.0:
                # a speed or velocity ratio of 0 (a stroke that did not move) read by an
                # instrument whose uncertainty is relative, where no model term adds any
                raise MeasurementError(
                    f"the reading {float(value):g} has zero standard uncertainty (the "
                    "instrument's uncertainty is relative and nothing else is uncertain "
                    "here); a stroke that does not move has no speed or velocity ratio to "
                    "read: leave the reading out, or state its uncertainty", field=name)

    def _moved(self, rig: Rig, cond: Condition) -> Arr:
        """Healthy readings at a moved condition (SimulationError when none)."""
        if self.fast:
            moved = self.maps.moved_nominal(cond) if isinstance(self.maps, FastMaps) else \
                nominal_observables(rig, cond)
            return np.asarray(moved[self.idx])
        ev = evaluator(rig, cond)
        ev.rewind()  # shared: from the healthy points, whatever was solved there before
        return self._vec(ev.nominal())

    def _vec(self, pred: dict[str, float]) -> Arr:
        return np.array([pred[n] for n in self.obs.names])

    def whitened(self, resid: Arr) -> Arr:
        """Residuals ``y − ŷ`` [SI] (last axis: the readings) → independent unit normals."""
        return np.asarray(resid @ self.white.T)

    def chi2_grid(self, pred: Arr) -> Arr:
        """χ² of this record at every point of a map (``pred[..., observables]``)."""
        r = self.whitened(self.obs.values - pred[..., self.idx])
        chi2 = np.sum(r * r, axis=-1)
        # a masked prediction (stall, no operating point) cannot produce the reading
        return np.asarray(np.where(np.isnan(chi2), np.inf, chi2))

    def as_dict(self, full: Arr) -> dict[str, float]:
        """Observables ``full`` [SI] by name (Python floats)."""
        return dict(zip(OBSERVABLES, np.asarray(full, dtype=np.float64).tolist(), strict=True))
