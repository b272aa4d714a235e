"""The best point of a one-parameter grid search and what refines it: its neighbours on
each side (the next, finer grid's bracket) and the vertex of the parabola through the three
(:mod:`diagnostics.range_test`, :mod:`diagnostics.healthy_end`)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = ["bracket", "parabola_vertex"]

Arr = npt.NDArray[np.float64]


def bracket(x: Arr, y: Arr) -> tuple[float, float]:
    """The nearest points on each side of the best of points ``(x, y)`` (the best point
    itself at an end)."""
    x, first = np.unique(x, return_index=True)  # sorted, each point once
    k = int(np.argmin(y[first]))
    return float(x[max(k - 1, 0)]), float(x[min(k + 1, x.size - 1)])


def parabola_vertex(x: Arr, y: Arr) -> float:
    """The vertex of the parabola through the best of points ``(x, y)`` and its nearest
    neighbour on each side (the best point itself when it has none or the parabola
    opens downward)."""
    x, first = np.unique(x, return_index=True)  # sorted, each point once
    y = y[first]
    j = int(np.argmin(y))
    if not 0 < j < x.size - 1 or not math.isfinite(float(y[j - 1] + y[j + 1])):
        return float(x[j])
    (x0, x1, x2), (y0, y1, y2) = x[j - 1:j + 2], y[j - 1:j + 2]
    den = (x0 - x1) * (x0 - x2) * (x1 - x2)
    if den == 0.0:
        return float(x1)
    ca = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / den
    cb = (x2 ** 2 * (y0 - y1) + x1 ** 2 * (y2 - y0) + x0 ** 2 * (y1 - y2)) / den
    if ca <= 0.0:
        return float(x1)
    return float(np.clip(-cb / (2.0 * ca), x0, x2))
