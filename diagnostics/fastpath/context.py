"""One rig at one condition in the arrays of the fast path's compiled kernels.

:class:`Context` holds a condition's working and return parameter vectors
(:func:`phase_vectors`), the Newton states the grid solves and the pair fits continue
from, and the factored Jacobians of the chord iterations (moving and held state, per
phase); :meth:`Context.probe` solves rows of graph parameter values by the compiled
:func:`~diagnostics.fastpath.chord.solve_grid`.  What depends on the rig only is built
once per rig (:func:`_layout`).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from types import ModuleType

import numpy as np
import numpy.typing as npt

from diagnostics.fastpath.compiled import compiled_kernels
from diagnostics.signatures import GRAPH_PARAMETERS, OBSERVABLES
from diagnostics.stroke_state import creep_speed
from sim.cycle import phase_settings
from sim.rigs import Condition, Rig
from sim.steady import SteadyEvaluator, steady_phase

__all__ = ["Context", "nominal_observables", "phase_vectors"]

Arr = npt.NDArray[np.float64]
IArr = npt.NDArray[np.int64]
#: a context's carried solver state: Newton states, chord Jacobians, pivots and validity
#: of the moving and the held state (:meth:`Context.saved`)
Saved = tuple[Arr, Arr, IArr, npt.NDArray[np.bool_], Arr, IArr, npt.NDArray[np.bool_]]

#: model outputs the observables are made of, in the order the kernel expects
_OUTPUTS = ("P_pump", "P1", "P2", "Q_meter_B", "Q_meter_C", "Q_relief", "v")

#: per rig (held, so that its id is not reused while here), what depends on the rig only
_LAYOUTS: OrderedDict[int, tuple[Rig, _Layout]] = OrderedDict()
_LOCK = threading.RLock()


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
    hjac, hpiv, hjac_valid
        The same of the end-stop state (a phase held on its stop).
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
        mh = int(np.count_nonzero(lay.mask == 1))
        self.hjac = np.zeros((2, mh, mh))
        self.hpiv = np.zeros((2, mh), dtype=np.int64)
        self.hjac_valid = np.zeros(2, dtype=np.bool_)
        self.creep = creep_speed(rig)
        self._start = self.saved()

    def saved(self) -> Saved:
        """Copies of what the solves carry from one call to the next: the Newton states
        and the chord iterations' factored Jacobians (:meth:`load` puts them back)."""
        return (self.states.copy(), self.jac.copy(), self.piv.copy(), self.jac_valid.copy(),
                self.hjac.copy(), self.hpiv.copy(), self.hjac_valid.copy())

    def load(self, saved: Saved) -> None:
        """Put back what :meth:`saved` copied."""
        for mine, kept in zip((self.states, self.jac, self.piv, self.jac_valid, self.hjac,
                               self.hpiv, self.hjac_valid), saved, strict=True):
            mine[:] = kept

    def mark(self) -> None:
        """Keep the present states and Jacobians as those :meth:`rewind` goes back to."""
        self._start = self.saved()

    def rewind(self) -> None:
        """Back to the states and Jacobians :meth:`mark` kept (at construction: the
        context's own).  A diagnosis starts here, so that its answer does not depend on
        what the context solved before: with the continuation and the chord Jacobians
        carried over, the same record diagnosed twice in one process differed by up to
        2e-5 relative in a χ², 1.7e-6 in an interval's bound (a determinism pass)."""
        self.load(self._start)

    def solve(self, grid: Arr, restart: IArr | None = None
              ) -> tuple[Arr, npt.NDArray[np.bool_]]:
        """Observables at each row of graph values ``grid`` (order of GRAPH_PARAMETERS);
        rows whose Newton failed are NaN and False.  ``restart`` marks (1) the first row
        of each run of equally spaced rows (a predictor runs along a run); default: every
        row alone."""
        out, ok, _, _ = self.probe(grid, restart)
        return out, ok

    def probe(self, grid: Arr, restart: IArr | None = None, starts: Arr | None = None
              ) -> tuple[Arr, npt.NDArray[np.bool_], Arr, Arr]:
        """:meth:`solve`, and per row the solutions of both phases, shape ``(n, 2,
        n_states)``, and their :func:`~diagnostics.fastpath.phase.drive` at the creep
        speed, shape ``(n, 2, 2)`` [m/s²].  ``restart`` 2 starts a run from
        ``starts[k]`` (a solution of both phases nearby) instead of the last solution."""
        n = grid.shape[0]
        out = np.empty((n, len(OBSERVABLES)))
        ok = np.zeros(n, dtype=np.bool_)
        flags = np.ones(n, dtype=np.int64) if restart is None else restart
        s = self.states
        ys = np.empty((n, 2, s.shape[1]))
        drv = np.empty((n, 2, 2))
        y0 = ys if starts is None else starts
        self.kernels.solve_grid(self.params[0], self.params[1], self.gidx,
                                np.ascontiguousarray(grid), self.mask, self.scale, s[0], s[1],
                                s[2], s[3], self.oi, out, ok, self.nout, flags,
                                self.use_chord, self.counts, self.creep, y0, ys, drv,
                                self.jac, self.piv, self.jac_valid, self.hjac, self.hpiv,
                                self.hjac_valid)
        return out, ok, ys, drv

    def nominal(self, base: Arr) -> Arr:
        """Observables at graph values ``base``; the nominal Newton states are set to the
        solution, and the context is marked there (:meth:`mark`).  Raises SimulationError
        where no steady point is found (transient start included)."""
        out, ok = self.solve(base[None, :])
        if not ok[0]:
            ev = SteadyEvaluator(self.rig, self.condition, GRAPH_PARAMETERS)
            out[0] = ev.vector(base, OBSERVABLES)
            self.states[0] = ev._last["working"]
            self.states[1] = ev._last["return"]
        self.states[2] = self.states[0]
        self.states[3] = self.states[1]
        self.mark()
        return out[0]


def nominal_observables(rig: Rig, condition: Condition) -> Arr:
    """Observables of the healthy rig at ``condition`` (graph values of the parameter
    vector, as :meth:`SteadyEvaluator.nominal`).  Raises SimulationError if none."""
    ctx = Context(rig, condition)
    return ctx.nominal(ctx.params[0][ctx.gidx])
