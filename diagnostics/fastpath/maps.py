"""Signature maps and healthy predictions of the fast path, solved in one compiled call.

:class:`FastMaps` is a :class:`~diagnostics.signatures.SignatureMaps` whose coarse grids
(every single-fault hypothesis, 130 points on the reference rig) are solved by one call of
the compiled :func:`~diagnostics.fastpath.kernel.solve_grid` and interpolated by the
compiled masked PCHIP (:func:`~diagnostics.fastpath.pchip.pchip_columns`), the
interpolation of :func:`~diagnostics.signatures.masked_pchip`.  Grids, pieces (the relief
kink) and masking are the direct maps'; the ridges between moving, creeping and held
strokes are located from the piston's drive (:mod:`diagnostics.fastpath.ridges`, all the
ridges of a condition together, a few compiled solves in all) to the width of the direct
maps' brackets, and the segments between them solved in one more grid solve.  A point
where Newton fails from the last and the nominal solution is retried by the direct
evaluator (start-up transient), as the direct path does.  :class:`Context`
(:mod:`diagnostics.fastpath.context`) holds one condition's parameter vectors and Newton
states, which the compiled pair fits (:mod:`diagnostics.fastpath.fits`) continue from.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Sequence
from functools import partial
from typing import TypeVar, cast

import numpy as np
import numpy.typing as npt

from diagnostics.fastpath.context import Context, nominal_observables, phase_vectors
from diagnostics.fastpath.ridges import Cut, Piece, locate
from diagnostics.fastpath.rows import Transform, piece_rows, set_rows, transform
from diagnostics.hypotheses import HYPOTHESES, PARAMETERS, FaultParameter, Hypothesis
from diagnostics.signatures import (
    FINE_1D,
    GRAPH_PARAMETERS,
    OBSERVABLES,
    HypothesisMap,
    Point,
    SignatureMaps,
    evaluator,
    ridge_segments,
)
from diagnostics.stroke_state import stroke_codes
from sim.errors import SimulationError
from sim.rigs import Condition, Rig
from sim.steady import SteadyEvaluator

__all__ = ["Context", "FastMaps", "Transform", "fast_maps", "nominal_observables",
           "phase_vectors", "transform"]

Arr = npt.NDArray[np.float64]
IArr = npt.NDArray[np.int64]

_MAPS: OrderedDict[tuple[int, Condition], FastMaps] = OrderedDict()
#: per rig, the parts of the maps that do not depend on the condition (:func:`_memo`)
_PIECES: OrderedDict[tuple[object, ...], tuple[Rig, object]] = OrderedDict()
_T = TypeVar("_T")
_LOCK = threading.RLock()


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


class FastMaps(SignatureMaps):
    """:class:`SignatureMaps` built by the compiled kernels (module docstring); ``chord``
    False solves the grid by the damped solver alone (the reference of the chord's test)."""

    def __init__(self, rig: Rig, condition: Condition, chord: bool = True) -> None:
        self.rig = rig
        self.condition = condition
        self._ev: SteadyEvaluator | None = None
        self._moved: dict[Condition, tuple[Context, Arr] | None] = {}
        self._point_grids: dict[tuple[Point, ...], Arr] = {}
        #: predictions that do not depend on the readings, kept for the next record at
        #: this condition with the phases' solutions and success (the range test's first
        #: grids, :mod:`diagnostics.range_test`)
        self.kept: dict[tuple[str, str, bytes], tuple[Arr, Arr, npt.NDArray[np.bool_]]] = {}
        self._base = np.array([rig.base[n] for n in GRAPH_PARAMETERS])
        self.ctx = Context(rig, condition, chord)
        try:
            self.nominal = self.ctx.nominal(self._base)
        except SimulationError:
            self.nominal = np.full(len(OBSERVABLES), np.nan)
        self.maps: dict[str, HypothesisMap] = {}
        hyps: list[tuple[Hypothesis, FaultParameter, Arr, int]] = []
        plans = []
        rows = []
        starts = []
        for hyp in HYPOTHESES:
            if len(hyp.parameters) != 1:
                continue
            (p,) = (PARAMETERS[n] for n in hyp.parameters)
            zf = _memo(rig, ("axis", p.name), partial(self._axis, p, FINE_1D))
            n_pieces = 0
            for lo, hi, n in self._pieces(p, float(zf[0]), float(zf[-1])):
                zc, g, first = _memo(rig, (p.name, lo, hi, n),
                                     partial(piece_rows, rig, p, self._base, lo, hi, n))
                plans.append((p, zc))
                rows.append(g)
                starts.append(first)
                n_pieces += 1
            hyps.append((hyp, p, zf, n_pieces))
        # every piece of every hypothesis in one grid solve, then every ridge located
        # together (:mod:`diagnostics.fastpath.ridges`), then every split piece in one solve
        out, ok, ys, drv = self.ctx.probe(np.concatenate(rows), np.concatenate(starts))
        pieces = []
        at = 0
        for p, zc in plans:
            sl = slice(at, at + zc.size)
            at += zc.size
            pieces.append(Piece(p, zc, self._retried(p, zc, out[sl], ok[sl].copy()), ys[sl],
                                drv[sl], ok[sl]))
        solved = self._split(pieces, locate(self, pieces))
        # the stroke states of every node of every map in one call
        codes = stroke_codes(np.concatenate([c for pcs in solved for _, c in pcs]),
                             self.ctx.creep)
        k = 0
        at = 0
        for hyp, p, zf, n_pieces in hyps:
            parts = [part for j in range(k, k + n_pieces) for part in solved[j]]
            k += n_pieces
            fine = np.empty((zf.size, len(OBSERVABLES)))
            ends = [float(zc[-1]) for zc, _ in parts]
            n = sum(zc.size for zc, _ in parts)
            self._mask_ratio_before_held_return([coarse for _, coarse in parts],
                                                codes[at:at + n])
            at += n
            cut = self._served(zf, ends)  # interpolated straight into the map's rows
            for j, (zc, coarse) in enumerate(parts):
                a, b = cut[j], cut[j + 1]
                self.ctx.kernels.pchip_columns(zc, np.ascontiguousarray(coarse), zf[a:b],
                                               fine[a:b])
            self.maps[hyp.name] = HypothesisMap(hyp, (p,), [zf], fine)
        self.ctx.mark()  # where every diagnosis at this condition starts (:meth:`rewind`)

    def rewind(self) -> None:
        """Every context of these maps back to where it was marked (built, and the maps
        solved; a moved condition's: its healthy point solved), and the direct
        evaluator's last solutions to the healthy ones: a diagnosis starts here, so that
        its answer depends on its records alone, not on what was diagnosed before at this
        condition (:meth:`Context.rewind`)."""
        self.ctx.rewind()
        for moved in self._moved.values():
            if moved is not None:
                moved[0].rewind()
        if self._ev is not None:
            self._ev.rewind()

    def _split(self, pieces: list[Piece], cuts: list[list[Cut]]) -> list[list[tuple[Arr, Arr]]]:
        """Each piece's segments (nodes, observables): the piece itself where it has no
        ridge, else its segments between the ridges' brackets
        (:func:`~diagnostics.signatures.ridge_segments`), all solved in one grid solve,
        each from the solution at its first node."""
        plan: list[list[Arr] | None] = []
        params: list[FaultParameter] = []
        flags: list[IArr] = []
        starts: list[Arr] = []
        for pc, cut in zip(pieces, cuts, strict=True):
            if not cut:
                plan.append(None)
                continue
            nodes: list[Arr] = []
            first_y = [pc.ys[0] if pc.ok[0] else None] + [c.y_hi for c in cut]
            for (a, b, m), y0 in zip(ridge_segments(pc.zc, [(c.lo, c.hi) for c in cut]),
                                     first_y, strict=True):
                nodes.append(np.linspace(a, b, m))
                params.extend([pc.p] * m)
                first = np.zeros(m, dtype=np.int64)
                y = np.empty((m, 2, pc.ys.shape[-1]))
                first[0] = 1 if y0 is None else 2
                if y0 is not None:
                    y[0] = y0
                flags.append(first)
                starts.append(y)
            plan.append(nodes)
        if params:  # the rows of every segment built at once (one call a parameter)
            zs = np.concatenate([z for nodes in plan if nodes is not None for z in nodes])
            out, ok, _, _ = self.ctx.probe(self._grid(params, zs), np.concatenate(flags),
                                           np.concatenate(starts))
        solved: list[list[tuple[Arr, Arr]]] = []
        at = 0
        for pc, planned in zip(pieces, plan, strict=True):
            if planned is None:
                solved.append([(pc.zc, pc.coarse)])
                continue
            parts: list[tuple[Arr, Arr]] = []
            for zs in planned:
                sl = slice(at, at + zs.size)
                at += zs.size
                parts.append((zs, self._retried(pc.p, zs, out[sl], ok[sl])))
            solved.append(parts)
        return solved

    def _grid(self, params: list[FaultParameter], zs: Arr) -> Arr:
        """Graph values with ``params[i]`` at ``zs[i]`` [fitting coordinate] in row ``i``."""
        grid = np.tile(self._base, (zs.size, 1))
        rows: dict[str, tuple[FaultParameter, list[int]]] = {}
        for i, p in enumerate(params):
            rows.setdefault(p.name, (p, []))[1].append(i)
        for p, at in rows.values():  # one call per parameter
            if len(at) == zs.size:
                set_rows(self.rig, p, grid, zs)
                continue
            sub = grid[at]
            set_rows(self.rig, p, sub, zs[at])
            grid[at] = sub
        return grid

    def probe_moving(self, params: list[FaultParameter], zs: list[Arr],
                     starts: list[Arr | None], even: bool = False
                     ) -> tuple[Arr, Arr, Arr, npt.NDArray[np.bool_]]:
        """Observables, solutions, drives and success (:meth:`Context.probe`) at runs of
        points: run ``j`` at fitting coordinates ``zs[j]`` of its parameters (``params``,
        one per point), the first started from ``starts[j]`` (the phases' solutions
        nearby; None: the last solution), each next one from the one before (``even``:
        runs of equally spaced points, each next one from the solutions before it
        extrapolated, as the maps' grids).  Points the compiled solve fails are retried
        by the direct evaluator (observables only)."""
        flat = np.concatenate(zs)
        flags = np.ones(flat.size, dtype=np.int64)
        if even:
            flags[:] = 0
            flags[np.cumsum([0] + [z.size for z in zs[:-1]])] = 1
        y0 = np.empty((flat.size, 2, self.ctx.states.shape[1]))
        at = 0
        for z, y in zip(zs, starts, strict=True):
            if y is not None and z.size:
                y0[at] = y
                flags[at] = 2
            at += z.size
        out, ok, ys, drv = self.ctx.probe(self._grid(params, flat), flags, y0)
        for i in np.flatnonzero(~ok):
            out[i] = self._solve_or_nan((params[i],), params[i].from_z(float(flat[i])))
        return out, ys, drv, ok

    def probe_fresh(self, params: list[FaultParameter], zs: list[Arr],
                    starts: list[Arr | None]) -> tuple[Arr, Arr, Arr, npt.NDArray[np.bool_]]:
        """:meth:`probe_moving` from where every diagnosis at this condition starts
        (:meth:`rewind`), everything the solvers carry left as it was: what it returns
        does not depend on what was solved before, and what is solved after it does not
        depend on whether it ran (predictions kept across records, :attr:`kept`)."""
        saved = self.ctx.saved()
        # the direct evaluator (retries of failed rows) is built only if a row fails: then
        # from its healthy points (:attr:`ev`), and left there as a new one would be
        direct = None if self._ev is None else self._ev.saved()
        self.ctx.rewind()
        if self._ev is not None:
            self._ev.rewind()
        try:
            return self.probe_moving(params, zs, starts)
        finally:
            self.ctx.load(saved)
            if self._ev is not None:
                if direct is None:
                    self._ev.rewind()
                else:
                    self._ev.load(direct)

    def probe_held(self, params: list[FaultParameter], phases: IArr, zs: list[Arr],
                   starts: list[Arr | None]) -> tuple[Arr, Arr, npt.NDArray[np.bool_]]:
        """The end-stop state's drive [m/s²] of phase ``phases[i]`` at point ``i``
        (:func:`~diagnostics.fastpath.phase.held_grid`), its solutions and success;
        arguments as :meth:`probe_moving` (a run starts from its phase's state in
        ``starts[j]``, None: the nominal one, and goes on from point to point)."""
        flat = np.concatenate(zs)
        n = flat.size
        ns = self.ctx.states.shape[1]
        flags = np.zeros(n, dtype=np.int64)
        y0 = np.empty((n, ns))
        at = 0
        for z, y in zip(zs, starts, strict=True):
            ph = int(phases[at])
            flags[at] = 1
            y0[at] = self.ctx.states[2 + ph] if y is None else y[ph] if y.ndim == 2 else y
            at += z.size
        g = np.empty(n)
        ys = np.empty((n, ns))
        ok = np.zeros(n, dtype=np.bool_)
        self.ctx.kernels.held_grid(self.ctx.params[0], self.ctx.params[1], self.ctx.gidx,
                                   self._grid(params, flat), np.asarray(phases, dtype=np.int64),
                                   self.ctx.mask, self.ctx.scale, flags, y0, ys, g, ok)
        return g, ys, ok

    def _retried(self, p: FaultParameter, zc: Arr, coarse: Arr, ok: npt.NDArray[np.bool_]
                 ) -> Arr:
        """``coarse`` with the rows whose compiled solve failed solved by the direct
        evaluator (start-up transient), NaN where that fails too."""
        for i in np.flatnonzero(~ok):
            coarse[i] = self._solve_or_nan((p,), p.from_z(float(zc[i])))
        return coarse

    def moved_nominal(self, condition: Condition) -> Arr:
        """Healthy observables at a condition near this one (the σ of a record's condition
        uncertainty), remembered with the maps.  Raises SimulationError if none."""
        moved = self._moved_context(condition)
        if moved is None:
            raise SimulationError(f"no healthy operating point at {condition}")
        return moved[1]

    def _moved_context(self, condition: Condition) -> tuple[Context, Arr] | None:
        """The kernel's context at a condition near this one and the healthy observables
        there (None where it has no healthy operating point), remembered with the maps."""
        if condition not in self._moved:
            ctx = Context(self.rig, condition)
            try:
                self._moved[condition] = (ctx, ctx.nominal(ctx.params[0][ctx.gidx]))
            except SimulationError:
                self._moved[condition] = None
        return self._moved[condition]

    def _point_grid(self, points: tuple[Point, ...]) -> Arr:
        """Graph values of ``points`` (rows), kept for the last few sets of points: the
        same estimates are solved at this condition and at the moved ones in turn."""
        grid = self._point_grids.get(points)
        if grid is not None:
            return grid
        grid = np.tile(self._base, (len(points), 1))
        rows: dict[str, tuple[FaultParameter, list[int], list[float]]] = {}
        for i, (params, zs) in enumerate(points):
            for p, z in zip(params, zs, strict=True):
                rows.setdefault(p.name, (p, [], []))[1].append(i)
                rows[p.name][2].append(z)
        for p, at, zvals in rows.values():  # one call per parameter
            sub = grid[at]
            set_rows(self.rig, p, sub, np.array(zvals))
            grid[at] = sub
        if len(self._point_grids) >= 4:
            self._point_grids.clear()
        self._point_grids[points] = grid
        return grid

    def observables_at_points(self, points: Sequence[Point],
                              condition: Condition | None = None) -> Arr:
        """:meth:`SignatureMaps.observables_at_points` on the compiled kernel (one call; at
        this condition a point it fails is solved directly, at a moved one it stays NaN).
        The context's Newton states are left as they were: the next fit at this condition
        starts where it would have (:meth:`SignatureMaps.observables_at` comes here)."""
        grid = self._point_grid(tuple(points))
        if condition is None or condition == self.condition:
            saved = self.ctx.states.copy()  # the maps' continuation is not moved by this
            out, ok = self.ctx.solve(grid)
            self.ctx.states[:] = saved
            for k in np.flatnonzero(~ok):
                params, zs = points[int(k)]
                try:
                    out[k] = self.predict(params, np.array([p.from_z(z) for p, z in
                                                            zip(params, zs, strict=True)]))
                except SimulationError:  # no steady operating point: the row stays NaN
                    out[k] = np.nan
            return out
        moved = self._moved_context(condition)
        if moved is None:
            return np.full((len(points), len(OBSERVABLES)), np.nan)
        out, ok = moved[0].solve(grid)
        out[~ok] = np.nan
        return out

    @property
    def ev(self) -> SteadyEvaluator:  # type: ignore[override]
        """The direct evaluator (built on first use: retries and the direct path)."""
        if self._ev is None:
            self._ev = evaluator(self.rig, self.condition)
            self._ev.rewind()  # shared: another user may have moved its last solutions
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
