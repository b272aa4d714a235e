"""Signature maps: every hypothesis's predicted readings over its whole prior range.

For one rig at one operating condition, each single-parameter hypothesis's parameter is
laid on a coarse grid in its fitting coordinate (:mod:`diagnostics.hypotheses`), every
grid point is solved by the steady-state fast path, and the predictions of all
observables are interpolated onto a fine grid (PCHIP: no overshoot at the kinks where the
relief valve opens or the piston stalls).  The maps do not depend on what was measured,
so they are cached per (rig, condition): a diagnosis at a known condition costs no model
evaluation for these hypotheses, and the likelihood of a record is a vectorised sum over
the fine grid.

Grid: 25 coarse → 241 fine points.  The interpolation error is below 4e-4 of the
readings wherever the piston still moves (tested against direct solves), far under the
instruments' 0.25-1 %.  Two-parameter hypotheses are not mapped: tensor-product splines
over 11 × 11 points erred by up to 2.5 % near the stall ridge, so pairs are fitted by
direct solves instead (:mod:`diagnostics.ranking`).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.interpolate import PchipInterpolator

from diagnostics.hypotheses import HYPOTHESES, PARAMETERS, FaultParameter, Hypothesis
from sim.rigs import Condition, Rig
from sim.steady import SteadyEvaluator

__all__ = ["GRAPH_PARAMETERS", "OBSERVABLES", "HypothesisMap", "SignatureMaps",
           "evaluator", "signature_maps"]

Arr = npt.NDArray[np.float64]

#: graph parameters the evaluators expose, in this order
GRAPH_PARAMETERS: tuple[str, ...] = ("cylinder.cc", "valve.cv", "pump.Rlp", "relief.Pset",
                                     "relief.Gseat")

#: observables of the maps, in this order (names of MeasurementRecord fields)
OBSERVABLES: tuple[str, ...] = ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "pump_flow",
                                "speed_work", "speed_return", "velocity_ratio")

COARSE_1D, FINE_1D = 25, 241

_EVALUATORS: OrderedDict[tuple[int, Condition], Any] = OrderedDict()
_MAPS: OrderedDict[tuple[int, Condition], Any] = OrderedDict()
#: guards the caches; a cached evaluator keeps per-call buffers, so sharing it is safe
_LOCK = threading.RLock()


def _lru_get(cache: OrderedDict[tuple[int, Condition], Any], key: tuple[int, Condition]
             ) -> Any:
    item = cache.get(key)
    if item is not None:
        cache.move_to_end(key)
    return item


def _lru_put(cache: OrderedDict[tuple[int, Condition], Any], key: tuple[int, Condition],
             item: object, size: int) -> None:
    cache[key] = item
    while len(cache) > size:
        cache.popitem(last=False)


def evaluator(rig: Rig, condition: Condition) -> SteadyEvaluator:
    """A cached :class:`SteadyEvaluator` of ``rig`` at ``condition`` (64 most recent)."""
    key = (id(rig), condition)
    with _LOCK:
        ev = _lru_get(_EVALUATORS, key)
        if ev is None:
            ev = SteadyEvaluator(rig, condition, GRAPH_PARAMETERS)
            _lru_put(_EVALUATORS, key, ev, 64)
    assert isinstance(ev, SteadyEvaluator)
    return ev


@dataclass
class HypothesisMap:
    """Fine-grid predictions of one hypothesis.

    Attributes
    ----------
    hypothesis
        The hypothesis.
    params
        Its fault parameters.
    axes
        Fine-grid fitting coordinates, one array per parameter.
    pred
        Predictions, shape ``(*fine_shape, len(OBSERVABLES))`` [SI].
    """

    hypothesis: Hypothesis
    params: tuple[FaultParameter, ...]
    axes: list[Arr]
    pred: Arr


class SignatureMaps:
    """Signature maps of every hypothesis for one rig at one condition."""

    def __init__(self, rig: Rig, condition: Condition) -> None:
        self.rig = rig
        self.condition = condition
        self.ev = evaluator(rig, condition)
        self._base = np.array([rig.base[n] for n in GRAPH_PARAMETERS])
        self.nominal = self.ev.vector(self._base, OBSERVABLES)
        self.maps: dict[str, HypothesisMap] = {}
        for hyp in HYPOTHESES:
            if len(hyp.parameters) == 1:
                self.maps[hyp.name] = self._build(hyp)

    def graph_values(self, params: tuple[FaultParameter, ...], values: Arr) -> Arr:
        """Graph parameter vector with ``params`` at ``values`` (reported units)."""
        g = self._base.copy()
        for p, v in zip(params, values, strict=True):
            g[GRAPH_PARAMETERS.index(p.graph_param)] = p.graph_value(self.rig, float(v))
        return g

    def predict(self, params: tuple[FaultParameter, ...], values: Arr) -> Arr:
        """Observables for ``params`` at ``values``, solved directly (no interpolation)."""
        return self.ev.vector(self.graph_values(params, values), OBSERVABLES)

    def _axis(self, p: FaultParameter, n: int) -> Arr:
        lo, hi = p.bounds(self.rig)
        return np.linspace(p.to_z(lo), p.to_z(hi), n)

    def _build(self, hyp: Hypothesis) -> HypothesisMap:
        params = tuple(PARAMETERS[n] for n in hyp.parameters)
        if len(params) == 1:
            (p,) = params
            zc = self._axis(p, COARSE_1D)
            coarse = np.array([self.predict(params, np.array([p.from_z(z)])) for z in zc])
            zf = self._axis(p, FINE_1D)
            fine = PchipInterpolator(zc, coarse, axis=0)(zf)
            return HypothesisMap(hyp, params, [zf], fine)
        raise ValueError("maps are built for one parameter; pairs are fitted directly")


def signature_maps(rig: Rig, condition: Condition) -> SignatureMaps:
    """Cached :class:`SignatureMaps` of ``rig`` at ``condition`` (32 most recent)."""
    key = (id(rig), condition)
    with _LOCK:
        maps = _lru_get(_MAPS, key)
        if maps is None:
            maps = SignatureMaps(rig, condition)
            _lru_put(_MAPS, key, maps, 32)
    assert isinstance(maps, SignatureMaps)
    return maps
