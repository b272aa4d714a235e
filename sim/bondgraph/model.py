"""A compiled bond graph: parameter vector, states, right-hand side, solvers."""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np
import numpy.typing as npt

from sim.bondgraph.codegen import generate_source, load_module
from sim.bondgraph.equations import EquationSystem, derive_equations
from sim.bondgraph.graph import BondGraph
from sim.bondgraph.tables import fit_table
from sim.errors import ParameterError, SimulationError, SolverLimitError
from sim.solver.limits import SolverLimits
from sim.solver.rodas import STATUS_NONFINITE, STATUS_PAUSED
from sim.solver.rosenbrock import STATUS_CAPACITY

__all__ = ["CompiledModel", "IntegrationResult", "compile_graph", "fit_table"]

Arr = npt.NDArray[np.float64]


@dataclass
class IntegrationResult:
    """Recorded trajectory of one integration.

    Attributes
    ----------
    t
        Times of accepted steps, or of the sampling grid within the run [s].
    y
        States at those times (rows).
    status
        0 end reached, 1 event, 3 step-size underflow (stopped early).
    rejected
        Rejected steps.
    t_final, y_final
        Time [s] and state where the run ended (the event point, or the end time).
    steps
        Accepted steps.
    nfev
        Right-hand-side evaluations (RODAS4; 0 when not counted).
    """

    t: Arr
    y: Arr
    status: int
    rejected: int
    t_final: float = 0.0
    y_final: Arr = field(default_factory=lambda: np.empty(0))
    steps: int = 0
    nfev: int = 0

    @property
    def success(self) -> bool:
        """True when the end time or the event was reached."""
        return self.status in (0, 1)


@dataclass
class CompiledModel:
    """State equations of a bond graph compiled to machine code.

    Use :meth:`params` to build a parameter vector (defaults overridden by name, tabulated
    inputs filled), :meth:`initial_state`, :meth:`integrate` and :meth:`steady`.
    The vector holds the named parameters (:attr:`param_names`, in declaration order),
    then one block per table (:meth:`table_block`).
    """

    system: EquationSystem
    module: ModuleType
    source: str
    state_names: list[str] = field(init=False)
    param_names: list[str] = field(init=False)
    output_names: list[str] = field(init=False)
    output_units: list[str] = field(init=False)
    scale: Arr = field(init=False)

    def __post_init__(self) -> None:
        self.state_names = [s.name for s in self.system.states]
        self.param_names = list(self.system.params)
        self.output_names = [o[0] for o in self.system.outputs]
        self.output_units = [o[2] for o in self.system.outputs]
        self.scale = np.array([s.scale for s in self.system.states], dtype=float)
        self._pidx = {n: i for i, n in enumerate(self.param_names)}
        self._sidx = {n: i for i, n in enumerate(self.state_names)}
        self._defaults: Arr | None = None   # the graph's parameter vector, built once

    # -- vectors ----------------------------------------------------------------------
    def params(self, overrides: Mapping[str, float] | None = None,
               tables: Mapping[str, tuple[npt.ArrayLike, npt.ArrayLike]] | None = None) -> Arr:
        """Parameter vector: graph defaults, then ``overrides`` by name, then ``tables``.

        Parameters
        ----------
        overrides
            Parameter name → value.
        tables
            Table name → ``(times [s], values)``; each series fills its block as
            :func:`fit_table` describes (copied, padded with its last point, or resampled
            to the declared size).  Tables not given hold their declared constant.
        """
        p = self._default_params().copy()
        if overrides:
            pidx = self._pidx
            try:
                where = [pidx[name] for name in overrides]
            except KeyError:
                name = next(n for n in overrides if n not in pidx)
                raise ParameterError(f"unknown parameter {name!r}", field=name) from None
            # one assignment for all: a rig sets every parameter (~100) for each phase, and
            # a Python loop of item assignments was the most of a steady cycle's time
            p[where] = np.fromiter(overrides.values(), dtype=float, count=len(where))
        for name, (times, values) in (tables or {}).items():
            self.set_table(p, name, times, values)
        return p

    def _default_params(self) -> Arr:
        """The graph's own parameter vector (its values and tables), built once: a compiled
        model's graph is not changed after compilation."""
        if self._defaults is not None:
            return self._defaults
        named = [self.system.graph.parameters[n].value for n in self.param_names]
        size = len(named) + sum(2 * n for _, n in self.system.tables.values())
        p = np.empty(size)
        p[: len(named)] = named
        for name, (offset, n) in self.system.tables.items():
            p[offset: offset + n] = 0.0
            p[offset + n: offset + 2 * n] = self.system.graph.tables[name].value
        p.flags.writeable = False
        self._defaults = p
        return p

    def table_block(self, name: str) -> tuple[int, int]:
        """``(offset, size)`` of table ``name``: times at ``p[offset:offset+size]``, values next."""
        if name not in self.system.tables:
            raise ParameterError(f"unknown table {name!r}", field=name)
        return self.system.tables[name]

    def set_table(self, p: Arr, name: str, times: npt.ArrayLike, values: npt.ArrayLike) -> None:
        """Fill table ``name`` of the parameter vector ``p`` in place (see :func:`fit_table`)."""
        offset, n = self.table_block(name)
        t, v = fit_table(times, values, n)
        p[offset: offset + n] = t
        p[offset + n: offset + 2 * n] = v

    def param_index(self, name: str) -> int:
        """Index of parameter ``name`` in the vector."""
        if name not in self._pidx:
            raise ParameterError(f"unknown parameter {name!r}", field=name)
        return self._pidx[name]

    def state_index(self, name: str) -> int:
        """Index of state ``name``."""
        return self._sidx[name]

    def initial_state(self, p: Arr) -> Arr:
        """Initial state from the elements' ``initial`` references."""
        y0 = np.empty(len(self.state_names))
        for i, st in enumerate(self.system.states):
            ref = st.initial
            y0[i] = p[self._pidx[ref[2:]]] if ref.startswith("p:") else float(ref)
        return y0

    # -- evaluation ---------------------------------------------------------------------
    def derivative(self, y: Arr, p: Arr, t: float = 0.0) -> Arr:
        """dy/dt at ``(t, y)``."""
        dy = np.empty_like(y)
        self.module.rhs(t, y, p, dy)
        return dy

    def bond_values(self, y: Arr, p: Arr, t: float = 0.0) -> tuple[Arr, Arr]:
        """(efforts, flows) of every bond at ``(t, y)``, indexed like ``graph.bonds``."""
        nb = len(self.system.graph.bonds)
        e, f = np.empty(nb), np.empty(nb)
        self.module.bond_values(t, np.ascontiguousarray(y, dtype=float), p, e, f)
        return e, f

    def outputs(self, t: Arr, y: Arr, p: Arr) -> Arr:
        """Outputs at the rows of ``y`` (shape ``(len(t), n_outputs)``)."""
        out = np.empty((t.size, len(self.output_names)))
        if self.output_names:
            self.module.outputs_batch(np.ascontiguousarray(t), np.ascontiguousarray(y), p, out)
        return out

    def integrate(self, y0: Arr, p: Arr, t_end: float, *, t0: float = 0.0, rtol: float = 1e-5,
                  h0: float = 1e-6, hmax: float = 0.05, event: tuple[str, float, float] | None = None,
                  capacity: int = 200_000, method: str = "ros2", atol: Arr | None = None,
                  times: Arr | None = None, limits: SolverLimits | None = None,
                  deadline: float | None = None) -> IntegrationResult:
        """Integrate with the compiled ROS2 or RODAS4 method (:mod:`sim.solver`).

        Parameters
        ----------
        y0, p
            Initial state and parameter vector.
        t_end
            End time [s].
        t0
            Start time [s].
        rtol
            Relative tolerance [-].
        h0, hmax
            Initial and maximum step [s].
        event
            ``(state name, level, direction)``: stop when the state crosses the level.
        capacity
            ROS2: size of the step buffer of one compiled call; a full buffer is copied out
            and the integration goes on (no limit on the number of recorded steps).
        method
            ``"ros2"`` (second order, one row per accepted step) or ``"rodas4"`` (fourth
            order, dense output, events on the dense output, optional sampling grid).
        atol
            RODAS4: absolute tolerance of each state [state unit]; default ``rtol·scale``.
            (ROS2 uses ``rtol·scale`` always.)
        times
            RODAS4: sampling grid [s]; the result holds the state at these times (within
            the integrated span) from the dense output.  ``None``: every accepted step.
        limits
            Step, simulated-time and wall-clock bounds (defaults of :class:`SolverLimits`).
        deadline
            ``time.perf_counter()`` value after which the run stops (overrides the
            budget of ``limits``; lets several integrations share one budget).

        Returns
        -------
        IntegrationResult
            Status 0 (end), 1 (event) or 3 (step size fell below round-off: the run
            stopped early; see :meth:`IntegrationResult.success`).

        Raises
        ------
        SolverLimitError
            The step limit, the simulated-time limit or the wall-clock budget was
            reached (the message says which, the tolerance and the time reached).
        SimulationError
            The state became non-finite (RODAS4).
        """
        lim = limits if limits is not None else SolverLimits()
        if t_end - t0 > lim.max_sim_time:
            raise SolverLimitError(
                f"simulated time {t_end - t0:.4g} s exceeds the limit {lim.max_sim_time:.4g} s")
        if deadline is None:
            deadline = lim.deadline()
        elif time.perf_counter() > deadline:
            raise SolverLimitError(
                f"wall-clock budget spent before the integration from t = {t0:.6g} s with "
                f"rtol {rtol:.3g}; loosen the tolerance or shorten the run", field="rtol")
        ev_i, ev_level, ev_dir = -1, 0.0, 1.0
        if event is not None:
            ev_i, ev_level, ev_dir = self._sidx[event[0]], float(event[1]), float(event[2])
        y0c = np.ascontiguousarray(y0, dtype=float)
        if method == "ros2":
            return self._integrate_ros2(y0c, p, float(t0), float(t_end), rtol, h0, hmax,
                                        (ev_i, ev_level, ev_dir), capacity, lim, deadline)
        if method != "rodas4":
            raise ParameterError(f"unknown integration method {method!r} (ros2, rodas4)",
                                 field="method")
        tol = rtol * self.scale if atol is None else np.ascontiguousarray(atol, dtype=float)
        grid = np.empty(0) if times is None else np.ascontiguousarray(times, dtype=float)
        t_parts: list[Arr] = []
        y_parts: list[Arr] = []
        t, y, h = float(t0), y0c, float(h0)
        steps = rejected = nfev = 0
        while True:
            chunk = min(lim.chunk_steps, lim.max_steps - steps - rejected)
            ts, ys, count, status, y, t, h, counters = self.module.integrate_rodas(
                t, float(t_end), y, p, tol, float(rtol), h, float(hmax), ev_i, ev_level,
                ev_dir, grid, int(chunk))
            steps += int(counters[0])
            rejected += int(counters[1])
            nfev += int(counters[2])
            # a resumed call records its start point (or a grid point on it) again: keep
            # each time once
            skip = 0
            if t_parts and any(part.size for part in t_parts):
                last = next(part[-1] for part in reversed(t_parts) if part.size)
                skip = int(np.searchsorted(ts[:count], last, side="right"))
            t_parts.append(ts[skip:count])
            y_parts.append(ys[skip:count])
            if status != STATUS_PAUSED:
                break
            self._check_limits(lim, deadline, steps + rejected, t, rtol)
        if status == STATUS_NONFINITE:
            raise SimulationError(f"the state became non-finite at t = {t:.6g} s")
        return IntegrationResult(np.concatenate(t_parts), np.concatenate(y_parts),
                                 int(status), rejected, t_final=float(t), y_final=y.copy(),
                                 steps=steps, nfev=nfev)

    def _check_limits(self, lim: SolverLimits, deadline: float | None, steps: int, t: float,
                      rtol: float) -> None:
        if steps >= lim.max_steps:
            raise SolverLimitError(
                f"step limit of {lim.max_steps} steps reached at t = {t:.6g} s with rtol "
                f"{rtol:.3g}; loosen the tolerance or shorten the run", field="rtol")
        if deadline is not None and time.perf_counter() > deadline:
            raise SolverLimitError(
                f"wall-clock budget spent at t = {t:.6g} s with rtol {rtol:.3g}; loosen "
                "the tolerance or shorten the run", field="rtol")

    def _integrate_ros2(self, y0: Arr, p: Arr, t0: float, t_end: float, rtol: float,
                        h0: float, hmax: float, ev: tuple[int, float, float], capacity: int,
                        lim: SolverLimits, deadline: float | None) -> IntegrationResult:
        cap = max(3, min(capacity, lim.max_steps))
        t_parts: list[Arr] = []
        y_parts: list[Arr] = []
        t, y, h = t0, y0, h0
        steps = rejected_total = 0
        while True:
            ts = np.empty(cap)
            ys = np.empty((cap, y.size))
            count, status, rejected = self.module.integrate(
                t, t_end, y, p, self.scale, float(rtol), float(h), float(hmax),
                ev[0], ev[1], ev[2], ts, ys)
            rejected_total += int(rejected)
            steps += count - 1 + int(rejected)
            t_parts.append(ts[: count] if not t_parts else ts[1: count])
            y_parts.append(ys[: count] if not y_parts else ys[1: count])
            t, y = float(ts[count - 1]), ys[count - 1].copy()
            if status != STATUS_CAPACITY:
                break
            h = float(ts[count - 1] - ts[count - 2]) if count >= 2 else h
            self._check_limits(lim, deadline, steps, t, rtol)
        tt, yy = np.concatenate(t_parts), np.concatenate(y_parts)
        return IntegrationResult(tt, yy, int(status), rejected_total, t_final=t,
                                 y_final=y, steps=int(tt.size - 1))

    def steady(self, y0: Arr, p: Arr, *, frozen: tuple[str, ...] = (), tol: float = 1e-10,
               maxit: int = 60) -> Arr:
        """Steady state: all derivatives zero except those of the ``frozen`` states.

        Raises
        ------
        SimulationError
            If Newton's method does not converge from ``y0``.
        """
        mask = np.ones(y0.size, dtype=np.int64)
        for name in frozen:
            mask[self._sidx[name]] = 0
        y = np.empty_like(y0)
        status, its, res = self.module.steady(np.ascontiguousarray(y0, dtype=float), p, mask,
                                              self.scale, float(tol), int(maxit), y)
        if status != 0:
            raise SimulationError(
                f"steady state not found (status {status} after {its} Newton iterations, "
                f"scaled residual {res:.3g})")
        return y

    def plain_rhs(self) -> Any:
        """The same right-hand side as plain (uncompiled) Python, for baselines."""
        return load_module(generate_source(self.system, jit=False)).rhs


def compile_graph(graph: BondGraph) -> CompiledModel:
    """Assign causality, derive and compile the state equations of ``graph``."""
    system = derive_equations(graph)
    source = generate_source(system)
    return CompiledModel(system, load_module(source), source)
