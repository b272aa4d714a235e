"""Grouping measured values into the nominal levels of a test plan.

A bench holds set points, but the readings scatter around them.  Steps that need equal
conditions (Toet's ∂Q/∂ω at a fixed pressure, paper 000 eq. 7 at equal pressure and speed
but two temperatures) first group the readings into levels: sorted values split wherever
the gap between neighbours exceeds ``max(rel_gap·|value|, abs_gap)``.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sim.errors import InputError

__all__ = ["cluster_levels", "group_keys"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def cluster_levels(values: npt.ArrayLike, *, rel_gap: float = 0.02, abs_gap: float = 0.0,
                   field: str = "values") -> tuple[IntArray, FloatArray]:
    """Group readings into levels.

    Parameters
    ----------
    values
        Readings of one factor [any unit].
    rel_gap
        Relative gap that separates two levels [-].
    abs_gap
        Absolute gap that separates two levels [unit of ``values``].
    field
        Name for error messages.

    Returns
    -------
    tuple of ndarray
        ``(index, level_means)``: the level of each reading (0 = lowest) and the mean reading
        of each level.
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    if v.size == 0 or not np.all(np.isfinite(v)):
        raise InputError("values must be finite and non-empty", field=field)
    order = np.argsort(v, kind="stable")
    s = v[order]
    tol = np.maximum(rel_gap * np.abs(s[1:]), abs_gap)
    new = np.concatenate([[0], (np.diff(s) > tol).astype(np.int64)])
    sorted_idx = np.cumsum(new)
    idx = np.empty_like(sorted_idx)
    idx[order] = sorted_idx
    means = np.bincount(idx, weights=v) / np.bincount(idx)
    return idx.astype(np.int64), means


def group_keys(*indices: IntArray) -> IntArray:
    """One integer key per combination of level indices (same key = same set point)."""
    if not indices:
        raise InputError("no indices", field="indices")
    stacked = np.stack([np.asarray(i, dtype=np.int64) for i in indices], axis=1)
    _, key = np.unique(stacked, axis=0, return_inverse=True)
    return np.asarray(key, dtype=np.int64).ravel()
