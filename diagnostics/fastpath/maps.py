"""Signature maps and healthy predictions of the fast path, solved in one compiled call.

:class:`FastMaps` is a :class:`~diagnostics.signatures.SignatureMaps` whose coarse grids
(every single-fault hypothesis, 130 points on the reference rig) are solved by one call of
the compiled :func:`~diagnostics.fastpath.kernel.solve_grid` and interpolated by the
compiled masked PCHIP (:func:`~diagnostics.fastpath.pchip.pchip_columns`), the
interpolation of :func:`~diagnostics.signatures.masked_pchip`.  Grids, pieces (the relief
kink, the moving/held ridges) and masking are the direct maps'; a point where Newton
fails from the last and the nominal solution is retried by the direct evaluator
(start-up transient), as the direct path does.  :class:`Context` holds one condition's
parameter vectors and Newton states, which the compiled pair fits
(:mod:`diagnostics.fastpath.fits`) continue from.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from types import ModuleType
from typing import TypeVar, cast

import numpy as np
import numpy.typing as npt

from diagnostics.fastpath.compiled import compiled_kernels
from diagnostics.hypotheses import HYPOTHESES, PARAMETERS, FaultParameter, Hypothesis
from diagnostics.signatures import (
    FINE_1D,
    GRAPH_PARAMETERS,
    OBSERVABLES,
    HypothesisMap,
    SignatureMaps,
    evaluator,
    stroke_codes,
)
from sim.cycle import phase_settings
from sim.errors import SimulationError
from sim.rigs import Condition, Rig
from sim.steady import SteadyEvaluator, steady_phase

__all__ = ["Context", "FastMaps", "Transform", "fast_maps", "nominal_observables",
           "phase_vectors", "transform"]

Arr = npt.NDArray[np.float64]
IArr = npt.NDArray[np.int64]

#: model outputs the observables are made of, in the order the kernel expects
_OUTPUTS = ("P_pump", "P1", "P2", "Q_meter_B", "Q_meter_C", "Q_relief", "v")

#: per rig (held, so that its id is not reused while here), what depends on the rig only
_LAYOUTS: OrderedDict[int, tuple[Rig, _Layout]] = OrderedDict()
_MAPS: OrderedDict[tuple[int, Condition], FastMaps] = OrderedDict()
#: per rig, the parts of the maps that do not depend on the condition (:func:`_memo`)
_PIECES: OrderedDict[tuple[object, ...], tuple[Rig, object]] = OrderedDict()
_T = TypeVar("_T")
_LOCK = threading.RLock()


@dataclass(frozen=True)
class Transform:
    """Fitting coordinate → graph parameter of a fault parameter, in numbers the kernel
    reads: ``g = c·v`` (mode 0) or ``c/v`` (mode 1), ``v = exp(z)`` if ``log`` else ``z``."""

    index: int
    log: bool
    mode: int
    const: float

    def graph(self, z: Arr) -> Arr:
        """Graph values [SI] at fitting coordinates ``z``."""
        v = np.exp(z) if self.log else np.asarray(z, dtype=np.float64)
        return np.asarray(self.const * v if self.mode == 0 else self.const / v)


def transform(rig: Rig, p: FaultParameter) -> Transform | None:
    """The :class:`Transform` of ``p`` read off :meth:`FaultParameter.graph_value` (one
    proportional or inverse law), or None when it is neither (then the direct path runs);
    kept per rig."""
    return _memo(rig, ("transform", p), partial(_transform, rig, p))


def _transform(rig: Rig, p: FaultParameter) -> Transform | None:
    g1, g2 = p.graph_value(rig, 1.0), p.graph_value(rig, 2.0)
    index = GRAPH_PARAMETERS.index(p.graph_param)
    if g1 != 0.0 and math.isclose(g2, 2.0 * g1, rel_tol=1e-12):
        return Transform(index, p.log, 0, g1)
    if g1 != 0.0 and math.isclose(g2, 0.5 * g1, rel_tol=1e-12):
        return Transform(index, p.log, 1, g1)
    return None


@dataclass(frozen=True)
class _Layout:
    """What a :class:`Context` needs that depends on the rig only (built once per rig)."""

    kernels: ModuleType
    gidx: IArr
    #: solver mask per state: 1 solved, 0 held (the position), 2 the piston's velocity
    #: (solved when moving, held at 0 in the end-stop state)
    mask: IArr
    scale: Arr
    oi: IArr
    nout: int
    states: Arr
    #: parameter indices and values that turn the working vector into the return one
    ret_idx: IArr
    ret_val: Arr
    work: dict[str, float]


def _layout(rig: Rig) -> _Layout:
    """The :class:`_Layout` of ``rig`` (cached per rig; the Newton starts are the nominal
    points of both phases at the default condition, the piston at mid-stroke)."""
    with _LOCK:
        entry = _LAYOUTS.get(id(rig))
    if entry is not None and entry[0] is rig:
        return entry[1]
    m = rig.model
    cond = rig.default_condition()
    sw = steady_phase(rig, "working", None, cond).state.copy()
    sr = steady_phase(rig, "return", None, cond).state.copy()
    ix = m.state_index("cylinder.x")
    sw[ix] = sr[ix] = 0.5 * rig.base["cylinder.stroke"]
    mask = np.ones(len(m.state_names), dtype=np.int64)
    mask[ix] = 0
    mask[m.state_index("cylinder.mass")] = 2  # held at 0 in the end-stop state
    ret = phase_settings(rig, "return")
    lay = _Layout(
        compiled_kernels(rig),
        np.array([m.param_index(n) for n in GRAPH_PARAMETERS], dtype=np.int64), mask,
        m.scale, np.array([m.output_names.index(n) for n in _OUTPUTS], dtype=np.int64),
        len(m.output_names), np.array([sw, sr, sw, sr]),
        np.array([m.param_index(n) for n in ret], dtype=np.int64),
        np.array(list(ret.values()), dtype=np.float64), phase_settings(rig, "working"))
    with _LOCK:
        _LAYOUTS[id(rig)] = (rig, lay)
        while len(_LAYOUTS) > 16:
            _LAYOUTS.popitem(last=False)
    return lay


def phase_vectors(rig: Rig, condition: Condition) -> Arr:
    """Working and return parameter vectors at ``condition``, shape ``(2, n_params)``: the
    vectors of :func:`sim.cycle.phase_params` from one evaluation of the rig's values (the
    return vector is the working one with the return phase's settings)."""
    lay = _layout(rig)
    values = rig.values(None, condition)
    values.update(lay.work)
    pw = rig.model.params(values)
    pr = pw.copy()
    pr[lay.ret_idx] = lay.ret_val
    return np.array([pw, pr])


class Context:
    """One rig at one condition, in the kernel's arrays.

    Attributes
    ----------
    params
        Working and return parameter vectors, shape ``(2, n_params)``.
    states
        Newton states: last working, last return, nominal working, nominal return,
        shape ``(4, n_states)``; the last ones move with every solve (continuation).
    use_chord
        Grid solves try the chord Newton first (:mod:`diagnostics.fastpath.chord`; the
        ``chord`` argument, default True); False: the damped solver alone.
    counts
        Phase solves of the grid solves so far: settled by the chord iteration (0), its
        failures by reason (1-4, :func:`~diagnostics.fastpath.chord.chord`), damped (5).
    jac, piv, jac_valid
        Per phase the LU-factored Jacobian at a recent solution of the pair fits, its
        pivots and whether it holds one (the chord iteration of
        :func:`diagnostics.fastpath.kernel.solve_point` runs on it; kept with the context,
        so the next diagnosis at this condition starts with it).
    """

    def __init__(self, rig: Rig, condition: Condition, chord: bool = True) -> None:
        lay = _layout(rig)
        self.rig = rig
        self.condition = condition
        self.kernels = lay.kernels
        self.params = phase_vectors(rig, condition)
        self.gidx = lay.gidx
        self.mask = lay.mask
        self.scale = lay.scale
        self.oi = lay.oi
        self.nout = lay.nout
        self.states = lay.states.copy()
        self.use_chord = chord
        self.counts = np.zeros(6, dtype=np.int64)
        m = int(np.count_nonzero(lay.mask))
        self.jac = np.zeros((2, m, m))
        self.piv = np.zeros((2, m), dtype=np.int64)
        self.jac_valid = np.zeros(2, dtype=np.bool_)

    def solve(self, grid: Arr, restart: IArr | None = None
              ) -> tuple[Arr, npt.NDArray[np.bool_]]:
        """Observables at each row of graph values ``grid`` (order of GRAPH_PARAMETERS);
        rows whose Newton failed are NaN and False.  ``restart`` marks (1) the first row
        of each run of equally spaced rows (a predictor runs along a run); default: every
        row alone."""
        n = grid.shape[0]
        out = np.empty((n, len(OBSERVABLES)))
        ok = np.zeros(n, dtype=np.bool_)
        flags = np.ones(n, dtype=np.int64) if restart is None else restart
        s = self.states
        self.kernels.solve_grid(self.params[0], self.params[1], self.gidx,
                                np.ascontiguousarray(grid), self.mask, self.scale, s[0], s[1],
                                s[2], s[3], self.oi, out, ok, self.nout, flags,
                                self.use_chord, self.counts)
        return out, ok

    def nominal(self, base: Arr) -> Arr:
        """Observables at graph values ``base``; the nominal Newton states are set to the
        solution.  Raises SimulationError where no steady point is found (transient start
        included)."""
        out, ok = self.solve(base[None, :])
        if not ok[0]:
            ev = SteadyEvaluator(self.rig, self.condition, GRAPH_PARAMETERS)
            out[0] = ev.vector(base, OBSERVABLES)
            self.states[0] = ev._last["working"]
            self.states[1] = ev._last["return"]
        self.states[2] = self.states[0]
        self.states[3] = self.states[1]
        return out[0]


def nominal_observables(rig: Rig, condition: Condition) -> Arr:
    """Observables of the healthy rig at ``condition`` (graph values of the parameter
    vector, as :meth:`SteadyEvaluator.nominal`).  Raises SimulationError if none."""
    ctx = Context(rig, condition)
    return ctx.nominal(ctx.params[0][ctx.gidx])


def _memo(rig: Rig, key: tuple[object, ...], make: Callable[[], _T]) -> _T:
    """What ``make`` returns for ``rig`` and ``key``, kept (the 64 most recent) for the
    next condition: the parts of a map that do not depend on the condition."""
    full = (id(rig), *key)
    with _LOCK:
        hit = _PIECES.get(full)
        if hit is not None and hit[0] is rig:
            _PIECES.move_to_end(full)
            return cast(_T, hit[1])
    value = make()
    with _LOCK:
        _PIECES[full] = (rig, value)
        while len(_PIECES) > 64:
            _PIECES.popitem(last=False)
    return value


def _piece_rows(rig: Rig, p: FaultParameter, base: Arr, lo: float, hi: float, n: int
                ) -> tuple[Arr, Arr, IArr]:
    """A map piece's coarse nodes ``zc`` (``n`` from ``lo`` to ``hi`` in fitting
    coordinates), the graph values of its rows and its run flags (1 at the first row)."""
    zc = np.linspace(lo, hi, n)
    tr = transform(rig, p)
    g = np.tile(base, (n, 1))
    if tr is not None:
        g[:, tr.index] = tr.graph(zc)
    else:
        g[:, GRAPH_PARAMETERS.index(p.graph_param)] = [
            p.graph_value(rig, p.from_z(float(z))) for z in zc]
    return zc, g, (np.arange(n) == 0).astype(np.int64)


class FastMaps(SignatureMaps):
    """:class:`SignatureMaps` built by the compiled kernels (module docstring); ``chord``
    False solves the grid by the damped solver alone (the reference of the chord's test)."""

    def __init__(self, rig: Rig, condition: Condition, chord: bool = True) -> None:
        self.rig = rig
        self.condition = condition
        self._ev: SteadyEvaluator | None = None
        self._moved: dict[Condition, Arr | None] = {}
        self._base = np.array([rig.base[n] for n in GRAPH_PARAMETERS])
        self.ctx = Context(rig, condition, chord)
        try:
            self.nominal = self.ctx.nominal(self._base)
        except SimulationError:
            self.nominal = np.full(len(OBSERVABLES), np.nan)
        self.maps: dict[str, HypothesisMap] = {}
        plans = []
        rows = []
        starts = []
        for hyp in HYPOTHESES:
            if len(hyp.parameters) != 1:
                continue
            (p,) = (PARAMETERS[n] for n in hyp.parameters)
            zf = _memo(rig, ("axis", p.name), partial(self._axis, p, FINE_1D))
            pieces = []
            for lo, hi, n in self._pieces(p, float(zf[0]), float(zf[-1])):
                zc, g, first = _memo(rig, (p.name, lo, hi, n),
                                     partial(_piece_rows, rig, p, self._base, lo, hi, n))
                pieces.append(zc)
                rows.append(g)
                starts.append(first)
            plans.append((hyp, p, zf, pieces))
        coarse_all, ok = self.ctx.solve(np.concatenate(rows), np.concatenate(starts))
        start = 0
        for hyp, p, zf, pieces in plans:
            solved = []
            for zc in pieces:
                coarse = self._retried(p, zc, coarse_all[start:start + zc.size],
                                       ok[start:start + zc.size])
                start += zc.size
                split = self._ridge_pieces(p, zc, coarse)
                if split is None:
                    solved.append((zc, coarse))
                    continue
                for a, b, m in split:
                    zs, g, first = _piece_rows(rig, p, self._base, a, b, m)
                    out, good = self.ctx.solve(g, first)
                    solved.append((zs, self._retried(p, zs, out, good)))
            fine = np.empty((zf.size, len(OBSERVABLES)))
            ends = [float(zc[-1]) for zc, _ in solved]
            self._mask_ratio_before_held_return([coarse for _, coarse in solved])
            for k, (zc, coarse) in enumerate(solved):
                sel = self._selection(zf, ends, k)
                part = np.empty((int(sel.sum()), len(OBSERVABLES)))
                self.ctx.kernels.pchip_columns(zc, np.ascontiguousarray(coarse), zf[sel], part)
                fine[sel] = part
            self.maps[hyp.name] = HypothesisMap(hyp, (p,), [zf], fine)

    def _retried(self, p: FaultParameter, zc: Arr, coarse: Arr, ok: npt.NDArray[np.bool_]
                 ) -> Arr:
        """``coarse`` with the rows whose compiled solve failed solved by the direct
        evaluator (start-up transient), NaN where that fails too."""
        for i in np.flatnonzero(~ok):
            coarse[i] = self._solve_or_nan((p,), p.from_z(float(zc[i])))
        return coarse

    def _states_on(self, p: FaultParameter, zs: Arr) -> npt.NDArray[np.int64]:
        """:func:`~diagnostics.signatures.stroke_codes` at ``zs`` by one compiled grid
        solve (the ridge bracketing of :meth:`SignatureMaps._ridge_pieces`; not counted
        in :attr:`Context.counts`, which describe the maps' grids)."""
        _, g, first = _piece_rows(self.rig, p, self._base, float(zs[0]), float(zs[-1]),
                                  zs.size)
        counts = self.ctx.counts.copy()
        out, ok = self.ctx.solve(g, first)
        self.ctx.counts[:] = counts
        return stroke_codes(self._retried(p, zs, out, ok), self._creep)

    def moved_nominal(self, condition: Condition) -> Arr:
        """Healthy observables at a condition near this one (the σ of a record's condition
        uncertainty), remembered with the maps.  Raises SimulationError if none."""
        if condition not in self._moved:
            try:
                self._moved[condition] = nominal_observables(self.rig, condition)
            except SimulationError:
                self._moved[condition] = None
        out = self._moved[condition]
        if out is None:
            raise SimulationError(f"no healthy operating point at {condition}")
        return out

    @property
    def ev(self) -> SteadyEvaluator:  # type: ignore[override]
        """The direct evaluator (built on first use: retries and the direct path)."""
        if self._ev is None:
            self._ev = evaluator(self.rig, self.condition)
        return self._ev

    def _build(self, hyp: Hypothesis) -> HypothesisMap:  # pragma: no cover - not used
        return self.maps[hyp.name]


def fast_maps(rig: Rig, condition: Condition) -> FastMaps:
    """Cached :class:`FastMaps` of ``rig`` at ``condition`` (32 most recent)."""
    key = (id(rig), condition)
    with _LOCK:
        maps = _MAPS.get(key)
        if maps is not None:
            _MAPS.move_to_end(key)
            return maps
    maps = FastMaps(rig, condition)
    with _LOCK:
        _MAPS[key] = maps
        while len(_MAPS) > 32:
            _MAPS.popitem(last=False)
    return maps
