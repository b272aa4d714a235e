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
