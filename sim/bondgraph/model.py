"""A compiled bond graph: parameter vector, states, right-hand side, solvers."""

from __future__ import annotations

from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np
import numpy.typing as npt

from sim.bondgraph.codegen import generate_source, load_module
from sim.bondgraph.equations import EquationSystem, derive_equations
from sim.bondgraph.graph import BondGraph
from sim.errors import ParameterError, SimulationError

__all__ = ["CompiledModel", "IntegrationResult", "compile_graph"]

Arr = npt.NDArray[np.float64]


@dataclass
class IntegrationResult:
    """Recorded trajectory of one integration.

    Attributes
    ----------
    t
        Times of accepted steps [s].
    y
        States at those times (rows).
    status
        0 end reached, 1 event, 2 buffer full, 3 step-size underflow.
    rejected
        Rejected steps.
    """

    t: Arr
    y: Arr
    status: int
    rejected: int

    @property
    def success(self) -> bool:
        """True when the end time or the event was reached."""
        return self.status in (0, 1)


@dataclass
class CompiledModel:
    """State equations of a bond graph compiled to machine code.

    Use :meth:`params` to build a parameter vector (defaults overridden by name),
    :meth:`initial_state`, :meth:`integrate` and :meth:`steady`.
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

    # -- vectors ----------------------------------------------------------------------
    def params(self, overrides: dict[str, float] | None = None) -> Arr:
        """Parameter vector: graph defaults, then ``overrides`` by name."""
        p = np.array([self.system.graph.parameters[n].value for n in self.param_names])
        for name, value in (overrides or {}).items():
            if name not in self._pidx:
                raise ParameterError(f"unknown parameter {name!r}", field=name)
            p[self._pidx[name]] = float(value)
        return p

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
                  capacity: int = 200_000) -> IntegrationResult:
        """Integrate with the compiled ROS2 method (see :mod:`sim.solver.rosenbrock`).

        Parameters
        ----------
        y0, p
            Initial state and parameter vector.
        t_end
            End time [s].
        t0
            Start time [s].
        rtol
            Relative tolerance.
        h0, hmax
            Initial and maximum step [s].
        event
            ``(state name, level, direction)``: stop when the state crosses the level.
        capacity
            Maximum number of recorded steps.
        """
        ts = np.empty(capacity)
        ys = np.empty((capacity, y0.size))
        ev_i, ev_level, ev_dir = -1, 0.0, 1.0
        if event is not None:
            ev_i, ev_level, ev_dir = self._sidx[event[0]], float(event[1]), float(event[2])
        count, status, rejected = self.module.integrate(
            float(t0), float(t_end), np.ascontiguousarray(y0, dtype=float), p, self.scale,
            float(rtol), float(h0), float(hmax), ev_i, ev_level, ev_dir, ts, ys)
        return IntegrationResult(ts[:count].copy(), ys[:count].copy(), int(status), int(rejected))

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
