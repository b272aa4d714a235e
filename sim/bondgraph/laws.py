"""Constitutive laws shared by several elements, compiled with numba.

A *law* is a scalar function compiled in nopython mode (``@law``).  Bond-graph elements
name the law they use; the code generator imports it into the generated module so that
the equation is written exactly once, in the component module that owns it, with its
paper and equation number in the docstring.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = [
    "constant",
    "law",
    "linear_effort",
    "linear_flow",
    "negated",
    "product",
    "quotient",
    "smooth_sign",
    "table_lookup",
]

F = TypeVar("F", bound=Callable[..., Any])


def law(func: F) -> F:
    """Compile ``func`` as a nopython scalar law (cached on disk)."""
    compiled: F = njit(cache=True)(func)  # type: ignore[assignment]
    return compiled


@law
def constant(value: float) -> float:
    """A constant effort or flow (Se, Sf): returns ``value``."""
    return value


@law
def linear_flow(e: float, R: float) -> float:
    """Linear resistance, flow out: f = e / R [R in effort·s/flow]."""
    return e / R


@law
def linear_effort(f: float, R: float) -> float:
    """Linear resistance, effort out: e = R · f."""
    return R * f


@law
def product(a: float, b: float) -> float:
    """a · b (modulated sources and moduli)."""
    return a * b


@law
def quotient(a: float, b: float) -> float:
    """a / b."""
    return a / b


@law
def smooth_sign(v: float, v_s: float) -> float:
    """sgn(v) regularised over the scale ``v_s``: tanh(v / v_s).

    Coulomb friction and check valves switch sign at zero; a smooth switch keeps the
    Jacobian finite for the implicit solver.  With ``v_s`` a thousandth of the operating
    speed the steady forces differ from the sharp law by < 1e-6 relative.
    """
    return math.tanh(v / v_s)


@law
def negated(value: float) -> float:
    """−value (an effort source that represents a pressure *drop* along a 1-junction)."""
    return -value


@law
def table_lookup(t: float, p: npt.NDArray[np.float64], offset: int, n: int) -> float:
    """Value of a tabulated signal at time ``t`` [s]: linear interpolation, clamped at the ends.

    The table is the block ``p[offset : offset + 2n]`` of the parameter vector: ``n``
    non-decreasing times, then ``n`` values (:meth:`sim.bondgraph.BondGraph.table`; the
    reference ``"tbl:NAME"`` passes ``p, offset, n``).  With times ``t_0 ≤ … ≤ t_{n−1}``
    and values ``v_i``:

    * ``t ≤ t_0`` → ``v_0``; ``t ≥ t_{n−1}`` → ``v_{n−1}`` (held, no extrapolation);
    * otherwise, on the segment ``t_i ≤ t < t_{i+1}``,
      ``v_i + (t − t_i)·(v_{i+1} − v_i)/(t_{i+1} − t_i)``.

    A repeated time ``t_i = t_{i+1}`` is a jump; the signal is right-continuous there (the
    later value holds from ``t_i`` on).  Binary search: ``O(log n)`` per call.
    """
    t_first = p[offset]
    if t <= t_first:
        return p[offset + n]
    if t >= p[offset + n - 1]:
        return p[offset + 2 * n - 1]
    lo = 0
    hi = n - 1  # invariant: times[lo] <= t < times[hi]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if p[offset + mid] <= t:
            lo = mid
        else:
            hi = mid
    t0 = p[offset + lo]
    t1 = p[offset + hi]
    v0 = p[offset + n + lo]
    v1 = p[offset + n + hi]
    return v0 + (t - t0) * (v1 - v0) / (t1 - t0)
