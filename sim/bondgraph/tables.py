"""Tabulated inputs: fitting a sampled series to a table block of the parameter vector.

The block is read by :func:`~sim.bondgraph.laws.table_lookup` (linear, right-continuous at
a repeated time, holding the last value from the last time on).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sim.errors import ParameterError

__all__ = ["fit_table"]

Arr = npt.NDArray[np.float64]


def fit_table(times: npt.ArrayLike, values: npt.ArrayLike, size: int) -> tuple[Arr, Arr]:
    """Fit a sampled series to a table block of ``size`` points.

    * ``len == size``: the series as it is;
    * ``len < size``: the last point is repeated until the block is full.  A repeated final
      point changes nothing: :func:`~sim.bondgraph.laws.table_lookup` holds the last value
      from the last time on, so the interpolated signal is exactly the series';
    * ``len > size``: the series is resampled by linear interpolation at ``size`` equally
      spaced times from its first to its last time.  The ends are kept; features shorter
      than the new spacing ``(t_last − t_first)/(size − 1)`` are smoothed (a jump becomes
      a ramp of one spacing), and between the new points the signal is the chord of the
      series, off by at most ``spacing²/8 · max|v''|``.  Declare a larger table to avoid it.

    Parameters
    ----------
    times
        Sample times [s], finite and non-decreasing (a repeated time is a jump).
    values
        Values at those times [unit], finite.
    size
        Points of the block.

    Returns
    -------
    tuple of ndarray
        ``(times, values)`` of length ``size``.

    Raises
    ------
    ParameterError
        Empty, unequal lengths, non-finite entries or decreasing times.
    """
    t = np.asarray(times, dtype=np.float64).ravel()
    v = np.asarray(values, dtype=np.float64).ravel()
    if t.size == 0 or t.size != v.size:
        raise ParameterError("a table needs times and values of the same, non-zero length",
                             field="times")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise ParameterError("table times and values must be finite", field="values")
    if np.any(np.diff(t) < 0.0):
        raise ParameterError("table times must be non-decreasing", field="times")
    if t.size == size:
        return t.copy(), v.copy()
    if t.size < size:
        pad = size - t.size
        return np.concatenate([t, np.full(pad, t[-1])]), np.concatenate([v, np.full(pad, v[-1])])
    tu = np.linspace(t[0], t[-1], size)
    return tu, _interp_right(tu, t, v)


def _interp_right(x: Arr, t: Arr, v: Arr) -> Arr:
    """Linear interpolation that, like ``table_lookup``, is right-continuous at a jump."""
    i = np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 1)
    j = np.minimum(i + 1, t.size - 1)
    width = t[j] - t[i]
    w = np.divide(x - t[i], width, out=np.zeros_like(x), where=width > 0.0)
    return np.asarray(v[i] + np.clip(w, 0.0, 1.0) * (v[j] - v[i]), dtype=np.float64)
