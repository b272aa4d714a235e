"""Signature maps: every hypothesis's predicted readings over its whole (worn) prior range.

For one rig at one operating condition, each single-parameter hypothesis's parameter is
laid on a coarse grid in its fitting coordinate (:mod:`diagnostics.hypotheses`), every
grid point is solved by the steady-state fast path, and the predictions of all
observables are interpolated onto a fine grid (PCHIP: no overshoot at the kinks where the
relief valve opens or the piston stalls).  The maps do not depend on what was measured,
so they are cached per (rig, condition): a diagnosis at a known condition costs no model
evaluation for these hypotheses, and the likelihood of a record is a vectorised sum over
the fine grid.

Grid: 25 coarse → 241 fine points.  The interpolation error is below 4e-4 of the
readings where the piston moves at 30 % of its nominal speed or more (tested against
direct solves, every 13th node at 2.1 and 6.3 kN, 40 °C), far under the instruments'
0.25-1 %; a numerics pass measured up to 6.1e-4 on the working speed and 1.1e-3 on the
velocity ratio (≤ 0.21 of their uncertainty) down to 0.02 m/s.  In the creep band of a
stall ridge (below ≈ 4·v_s, 0.4 mm/s) the interpolated speed can be off by tens of per
cent of a speed that small (52 %, 160 uncertainties, on the valve map at 2.1 kN; the
pressures and flows there within 1.4 u); the same pass diagnosed exact creep-band records
of a worn valve right (valve, p 0.80).

Stall, creep and end stops: on some rigs (a hot differential cylinder at the worn end of
the clearance range, a heavy load) the load is more than the worn rig can push in a
phase.  The piston then sits on its end stop, and the steady model gives that state
(:mod:`sim.steady`, *End stops*): speed 0, the pressures and flows of the leak paths and
the relief at rest, so a stalled record is predicted like any other.  Between the
moving and the held state the readings have a kink (their slopes jump where the speed
reaches 0), which no spline through it follows: an axis whose coarse nodes change state
is split at the *ridge*, bracketed to 8e-5 of the axis (:data:`RIDGE_ROUNDS`), and each
side is mapped on its own nodes (:meth:`SignatureMaps._ridge_pieces`).  The velocity
ratio is undefined where the return stroke is held and grows without bound as it
stops; it is masked there and over the last coarse interval before such a ridge.  A
grid point with no operating point at all (neither moving nor held) is *masked* too:
its predictions are NaN, the interpolation runs over the valid points only, and a fine
point is valid only when both coarse points around it are.  The likelihood treats a
masked prediction as impossible for a record that reads it (:mod:`diagnostics.ranking`),
and :attr:`HypothesisMap.masked` states which share of the prior range was masked;
:attr:`HypothesisMap.held` which share has a piston on its stop.  Two-parameter
hypotheses are not mapped: tensor-product splines over 11 × 11 points erred by up to
2.5 % near the stall ridge, so pairs are fitted by direct solves instead (:mod:`diagnostics.ranking`).
"""

from __future__ import annotations

import contextlib
import math
import threading
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.interpolate import PchipInterpolator

from diagnostics.hypotheses import HYPOTHESES, PARAMETERS, FaultParameter, Hypothesis
from diagnostics.stroke_state import (
    CREEP,
    SPEED_COLUMNS,
    creep_speed,
    held_state,
    stroke_codes,
    stroke_states,
)
from sim.errors import SimulationError
from sim.rigs import Condition, Rig
from sim.steady import SteadyEvaluator

__all__ = ["CREEP", "GRAPH_PARAMETERS", "OBSERVABLES", "RIDGE_POINTS", "RIDGE_ROUNDS",
           "HypothesisMap", "Point", "SignatureMaps", "evaluator", "held_state", "masked_pchip",
           "ridge_segments", "signature_maps", "stroke_codes", "stroke_states"]

Arr = npt.NDArray[np.float64]

#: fault parameters and their fitting coordinates, set together (one hypothesis's estimate)
Point = tuple[tuple[FaultParameter, ...], tuple[float, ...]]

#: graph parameters the evaluators expose, in this order
GRAPH_PARAMETERS: tuple[str, ...] = ("cylinder.cc", "valve.cv", "pump.Rlp", "relief.Pset",
                                     "relief.Gseat")

#: observables of the maps, in this order (names of MeasurementRecord fields)
OBSERVABLES: tuple[str, ...] = ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "pump_flow",
                                "speed_work", "speed_return", "velocity_ratio")

COARSE_1D, FINE_1D = 25, 241
#: a ridge between moving and held is bracketed by this many rounds of as many equally
#: spaced solves inside the bracket (a coarse interval over 8³: 8e-5 of the axis) [-]
RIDGE_ROUNDS, RIDGE_POINTS = 3, 7
#: columns of the working and return speeds in :data:`OBSERVABLES` (0 on the end stop)
_SPEEDS = (OBSERVABLES.index("speed_work"), OBSERVABLES.index("speed_return"))
if _SPEEDS != SPEED_COLUMNS:  # the stroke-state functions read the speeds there
    raise ImportError("diagnostics.stroke_state.SPEED_COLUMNS is out of step with OBSERVABLES")
_RATIO = OBSERVABLES.index("velocity_ratio")

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

    @property
    def masked(self) -> Arr:
        """Per observable, the share of the fine grid with no prediction (stall or no
        steady operating point) [-]."""
        return np.asarray(np.mean(np.isnan(self.pred), axis=0), dtype=np.float64)

    @property
    def held(self) -> Arr:
        """Share of the fine grid with the piston on its end stop in the working and in
        the return phase [-] (two values)."""
        return np.asarray(np.mean(self.pred[:, list(_SPEEDS)] == 0.0, axis=0),
                          dtype=np.float64)


class SignatureMaps:
    """Signature maps of every hypothesis for one rig at one condition."""

    def __init__(self, rig: Rig, condition: Condition) -> None:
        self.rig = rig
        self.condition = condition
        self.ev = evaluator(rig, condition)
        # shared: from the healthy points, not from what another user solved last (the
        # ratio index's healthy ratio differed in its last digit between processes)
        self.ev.rewind()
        self._base = np.array([rig.base[n] for n in GRAPH_PARAMETERS])
        try:
            self.nominal = self.ev.vector(self._base, OBSERVABLES)
        except SimulationError:
            self.nominal = np.full(len(OBSERVABLES), np.nan)
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

    def observables_at(self, params: list[FaultParameter], zs: Arr,
                       condition: Condition | None = None) -> Arr:
        """Observables with ``params[i]`` at fitting coordinate ``zs[i]`` in row ``i`` (the
        other parameters at the rig document's values), at this condition or at
        ``condition``, solved directly (no interpolation); NaN rows where no steady
        operating point exists."""
        return self.observables_at_points(
            [((p,), (float(z),)) for p, z in zip(params, zs, strict=True)], condition)

    def observables_at_points(self, points: Sequence[Point],
                              condition: Condition | None = None) -> Arr:
        """:meth:`observables_at` with several parameters per row: row ``i`` with the
        parameters of ``points[i]`` at its fitting coordinates (a pair hypothesis's
        estimate)."""
        if condition is None or condition == self.condition:
            ev = self.ev
        else:  # a moved condition's: from its healthy points, whatever solved there before
            ev = evaluator(self.rig, condition)
            ev.rewind()
        out = np.full((len(points), len(OBSERVABLES)), np.nan)
        for i, (ps, zs) in enumerate(points):
            values = np.array([p.from_z(z) for p, z in zip(ps, zs, strict=True)])
            with contextlib.suppress(SimulationError):  # no steady point: the row stays NaN
                out[i] = ev.vector(self.graph_values(ps, values), OBSERVABLES)
        return out

    def _solve_or_nan(self, params: tuple[FaultParameter, ...], value: float) -> Arr:
        """Direct prediction, NaN everywhere where no steady operating point exists."""
        try:
            return self.predict(params, np.array([value]))
        except SimulationError:
            return np.full(len(OBSERVABLES), np.nan)

    def _pieces(self, p: FaultParameter, z_lo: float, z_hi: float
                ) -> list[tuple[float, float, int]]:
        """Coarse-grid segments (start, end, nodes) of a parameter's axis.

        The relief valve opens where its setting meets the healthy pump pressure
        (paper 002 eq. 6: ``Qrv = (Pp − Pset)/Rrv`` above ``Pset``, 0 below), a kink no
        spline through it follows; the ``Pset`` axis is split there, each side mapped on
        its own (above the kink the valve stays shut and the readings do not change).
        """
        if p.name == "Pset":
            kink = float(self.nominal[OBSERVABLES.index("pump_pressure")])
            if math.isfinite(kink) and z_lo < kink < z_hi:
                return [(z_lo, kink, COARSE_1D), (kink, z_hi, 5)]
        return [(z_lo, z_hi, COARSE_1D)]

    @property
    def _creep(self) -> float:
        """Speed below which a stroke counts as creeping [m/s] (:data:`CREEP` switching
        speeds of the friction law; kept per rig)."""
        return creep_speed(self.rig)

    def _states_on(self, p: FaultParameter, zs: Arr) -> npt.NDArray[np.int64]:
        """:func:`stroke_codes` of ``p`` at fitting coordinates ``zs`` (direct solves)."""
        return stroke_codes(np.array([self._solve_or_nan((p,), p.from_z(float(z)))
                                      for z in zs]), self._creep)

    def _ridge_pieces(self, p: FaultParameter, zc: Arr, coarse: Arr
                      ) -> list[tuple[float, float, int]] | None:
        """The segments (start, end, nodes) of a piece whose coarse nodes change stroke
        state (:func:`stroke_states`: moving, creeping, held; module docstring), split at
        each ridge; None when no adjacent nodes change state.  Each ridge is bracketed
        by :data:`RIDGE_ROUNDS` rounds of :data:`RIDGE_POINTS` equally spaced solves
        inside the bracket (one grid solve each; a coarse interval may hold two ridges:
        into the creep band and onto the stop); each side keeps a share of the nodes in
        proportion to its length, 5 at least."""
        states = stroke_codes(coarse, self._creep)
        change = (states[:-1] != states[1:]) & (states[:-1] >= 0) & (states[1:] >= 0)
        if not change.any():
            return None
        cuts: list[tuple[float, float]] = []
        for k in np.flatnonzero(change):
            a_st, end_st = int(states[k]), int(states[k + 1])
            a, end = float(zc[k]), float(zc[k + 1])
            for _ in range(3):  # at most: moving → creeping → held, and one spare
                if a_st == end_st:
                    break
                b, b_st = end, end_st
                for _ in range(RIDGE_ROUNDS):
                    zs = np.linspace(a, b, RIDGE_POINTS + 2)[1:-1]
                    sts = self._states_on(p, zs)
                    other = np.flatnonzero(sts != a_st)
                    if other.size == 0:
                        a = float(zs[-1])
                        continue
                    j = int(other[0])
                    if j > 0:
                        a = float(zs[j - 1])
                    b, b_st = float(zs[j]), int(sts[j])
                    if b_st < 0:
                        break
                if b_st < 0:  # no operating point inside: no cut here
                    break
                cuts.append((a, b))
                a, a_st = b, b_st
        return ridge_segments(zc, cuts) if cuts else None

    def _mask_ratio_before_held_return(self, coarses: list[Arr],
                                       code: npt.NDArray[np.int64] | None = None) -> None:
        """The velocity ratio NaN at a moving node next to a held return stroke, along the
        nodes of consecutive pieces ``coarses`` (in place; it grows without bound there,
        module docstring); ``code``: their nodes' stroke codes when known."""
        if code is None:
            code = stroke_codes(np.concatenate(coarses), self._creep)
        held = (code >= 0) & (code % 3 == 2)
        if not held.any():
            return
        near = np.zeros(code.size, dtype=bool)
        near[1:] |= held[:-1]
        near[:-1] |= held[1:]
        bad = np.flatnonzero(near & (code >= 0) & ~held)
        if bad.size == 0:
            return
        ends = np.cumsum([c.shape[0] for c in coarses])
        for i in bad:
            piece = int(np.searchsorted(ends, i, side="right"))
            row = int(i - (ends[piece - 1] if piece else 0))
            coarses[piece][row, _RATIO] = np.nan

    @staticmethod
    def _served(zf: Arr, ends: list[float]) -> list[int]:
        """Where in the fine axis ``zf`` (sorted) each of the pieces ending at ``ends``
        starts serving, and the axis's size: piece ``k`` serves ``zf[cut[k]:cut[k + 1]]``,
        from the end of the piece before (the first from −∞) to its own end (the last to
        +∞).  Across a ridge's bracket (8e-5 of the axis) the piece after it extrapolates
        back: on the held side the speed stays exactly 0."""
        return [0, *np.searchsorted(zf, ends[:-1], side="left").tolist(), int(zf.size)]

    def _axis(self, p: FaultParameter, n: int) -> Arr:
        lo, hi = p.worn_bounds(self.rig)
        return np.linspace(p.to_z(lo), p.to_z(hi), n)

    def _build(self, hyp: Hypothesis) -> HypothesisMap:
        params = tuple(PARAMETERS[n] for n in hyp.parameters)
        if len(params) == 1:
            (p,) = params
            zf = self._axis(p, FINE_1D)
            pieces = []
            for lo, hi, n in self._pieces(p, float(zf[0]), float(zf[-1])):
                zc = np.linspace(lo, hi, n)
                coarse = np.array([self._solve_or_nan(params, p.from_z(z)) for z in zc])
                split = self._ridge_pieces(p, zc, coarse)
                if split is None:
                    pieces.append((zc, coarse))
                    continue
                for a, b, m in split:
                    zs = np.linspace(a, b, m)
                    pieces.append((zs, np.array([self._solve_or_nan(params, p.from_z(z))
                                                 for z in zs])))
            fine = np.empty((zf.size, len(OBSERVABLES)))
            ends = [float(zc[-1]) for zc, _ in pieces]
            self._mask_ratio_before_held_return([coarse for _, coarse in pieces])
            cut = self._served(zf, ends)
            for k, (zc, coarse) in enumerate(pieces):
                fine[cut[k]:cut[k + 1]] = masked_pchip(zc, coarse, zf[cut[k]:cut[k + 1]])
            return HypothesisMap(hyp, params, [zf], fine)
        raise ValueError("maps are built for one parameter; pairs are fitted directly")


def ridge_segments(zc: Arr, cuts: list[tuple[float, float]]) -> list[tuple[float, float, int]]:
    """The segments (start, end, nodes) of a piece with coarse nodes ``zc`` split at the
    ridge brackets ``cuts`` (``(a, b)`` in order along the axis; a segment ends at ``a``,
    the next starts at ``b``): each keeps a share of the nodes in proportion to its
    length, 5 at least."""
    span = float(zc[-1] - zc[0])
    out = []
    start = float(zc[0])
    for a, b in [*cuts, (float(zc[-1]), math.nan)]:
        n = max(5, math.ceil((zc.size - 1) * (a - start) / span) + 1)
        out.append((start, a, n))
        start = b
    return out


def masked_pchip(zc: Arr, coarse: Arr, zf: Arr) -> Arr:
    """PCHIP of ``coarse[k, j]`` (nodes ``zc``) onto ``zf``, column by column, over the
    finite nodes only; a fine point is NaN unless both nodes around it are finite.

    Parameters
    ----------
    zc
        Coarse nodes, increasing [fitting coordinate].
    coarse
        Values at the nodes, shape ``(len(zc), m)``; NaN where masked [SI].
    zf
        Fine points within ``[zc[0], zc[-1]]`` [fitting coordinate].

    Returns
    -------
    ndarray
        Shape ``(len(zf), m)`` [SI].
    """
    ok = np.isfinite(coarse)
    if ok.all():
        return np.asarray(PchipInterpolator(zc, coarse, axis=0)(zf), dtype=np.float64)
    fine = np.full((zf.size, coarse.shape[1]), np.nan)
    right = np.clip(np.searchsorted(zc, zf, side="left"), 1, zc.size - 1)
    for j in range(coarse.shape[1]):
        good = ok[:, j]
        if good.sum() < 2:
            continue
        col = PchipInterpolator(zc[good], coarse[good, j])(zf)
        valid = good[right] & good[right - 1]
        fine[valid, j] = col[valid]
    return fine


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
