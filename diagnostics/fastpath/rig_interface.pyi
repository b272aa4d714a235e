"""What a rig's generated module (:mod:`sim.bondgraph.codegen`) provides to the fast-path kernels.

The kernels of :mod:`diagnostics.fastpath.kernel` are compiled below
``from <rig module> import steady, outputs, rhs, lu_factor, lu_solve``; this declaration
names those functions
and their signatures for the type checker and the reader.
"""

import numpy as np
import numpy.typing as npt

_Arr = npt.NDArray[np.float64]
_IArr = npt.NDArray[np.int64]

def steady(y0: _Arr, p: _Arr, mask: _IArr, scale: _Arr, tol: float, maxit: int,
           y: _Arr) -> tuple[int, int, float]:
    """The rig's damped Newton solver (:func:`sim.solver.rosenbrock.steady` on its RHS)."""

def outputs(t: float, y: _Arr, p: _Arr, out: _Arr) -> None:
    """The rig's output function: writes every declared output into ``out``."""

def rhs(t: float, y: _Arr, p: _Arr, dy: _Arr) -> None:
    """The rig's right-hand side: writes dy/dt at state ``y`` into ``dy``."""

def lu_factor(a: _Arr, piv: _IArr) -> bool:
    """LU factorisation with partial pivoting in place; False when singular."""

def lu_solve(a: _Arr, piv: _IArr, b: _Arr) -> None:
    """Solves with the factors of :func:`lu_factor`, in place in ``b``."""
