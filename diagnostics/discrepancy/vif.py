"""Variance inflation factor of each candidate term on a balance's test design.

DISCREPANCY.md ("Pitfalls"): collinearity is the rule on these designs, and a VIF filter
removed whole entries in the prototype (turbulent leakage, compressibility, offset and
filling, 0 % found at VIF > 10).  So the VIF is *reported*, beside each candidate's
minimum detectable size (which grows with √VIF), and nothing is filtered on it.

The VIF of candidate ``j`` is taken in the model the selection fits for it alone: the
balance's base columns (always in) plus that one column, ``VIF_j = 1/(1 − R²_j)`` with
``R²_j`` the share of the column that the base columns explain by least squares.  The
balances have no intercept (every column is a physical term), so ``R²_j`` is the
uncentred one, ``1 − ‖M x_j‖²/‖x_j‖²`` with ``M`` the projection off the base columns:
then ``VIF_j`` is exactly the factor by which the base columns inflate the variance of the
candidate's coefficient over an orthogonal design, ``[(XᵀX)⁻¹]_jj·‖x_j‖²``, the diagonal
of the inverse of the design's (uncentred) correlation matrix.  It is the same with the
columns on any scale (the selection's unit-RMS columns give the same number).  Two columns
of mean zero and correlation ``r`` give ``1/(1 − r²)`` (tested).

Computed with numpy, not by ``statsmodels.stats.outliers_influence.variance_inflation_factor``:
that function regresses the column on the others *as given*, and from statsmodels 0.15 it
first standardises every column (``standardize=True`` by default: means removed), i.e. it
reports the VIF of a model *with* an intercept — the centred R², which these balances'
fits do not have (on the bench study's design √Δp beside Δp and ω reads 69 uncentred, 49
centred; the speed offset, a constant column, 13 and 1.0: centring removes it); with
``standardize=False`` (or 0.14, on a design without a constant) it gives the number here
(tested).  A least-squares projection also takes a rank-deficient base and a candidate in
the base columns' span (infinite: the ambiguity group ``base + …``) without a division by
zero or a warning.  The paper-001 loss models' VIF (:func:`diagnostics.pump.selection.vif`)
is the centred one, rightly: those models hold a constant term.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

__all__ = ["candidate_vif", "vif"]

Arr = npt.NDArray[np.float64]


def vif(base: Arr, column: Arr) -> float:
    """VIF of ``column`` beside the columns of ``base`` (``n × k``; ``k`` may be 0):
    ``‖x‖²/‖M x‖²`` (module docstring); ``inf`` for a column of zeros or one in the
    span of ``base`` to rounding."""
    x = np.asarray(column, dtype=float)
    total = float(x @ x)
    if total == 0.0 or not math.isfinite(total):
        return math.inf
    B = np.asarray(base, dtype=float).reshape(x.size, -1)
    if B.shape[1] == 0:
        return 1.0
    coef, *_ = np.linalg.lstsq(B, x, rcond=None)
    rest = x - B @ coef
    left = float(rest @ rest)
    if left <= 1e-24 * total:   # nothing left beyond rounding: the column is in the span
        return math.inf
    return total / left


def candidate_vif(base: Mapping[str, Arr], candidates: Mapping[str, Arr]) -> dict[str, float]:
    """VIF of each candidate column with the base columns present (module docstring), by
    candidate name; columns scaled to unit RMS first, as the selection scales them (the
    VIF does not depend on it; the scaling keeps the projection well conditioned)."""
    def unit(c: Arr) -> Arr:
        c = np.asarray(c, dtype=float)
        rms = float(np.sqrt(np.mean(c * c))) if c.size else 0.0
        return c / rms if rms > 0.0 and math.isfinite(rms) else c

    names = list(base)
    n = next((np.asarray(c).size for c in [*base.values(), *candidates.values()]), 0)
    B = (np.column_stack([unit(base[k]) for k in names]) if names
         else np.zeros((n, 0)))
    return {k: vif(B, unit(c)) for k, c in candidates.items()}
