"""Progressively sequenced regression (PSR): where coefficients and S saturate (paper 001 §3.4).

The data set is put in a random order and a fixed model is fitted to its first m points for
m = k + 2 … N, one point more each step; the coefficients and the mean standard error S
are recorded.  Data saturation is where they stop changing beyond random variation.

Saturation criteria used here (the paper gives the first in words, the second is ours):

* **S**: from m on, S stays within ±``s_band`` (10 %) of its terminal value S_N (paper 001
  §3.4: "randomly fluctuated within a range of ± 10 % of the terminal value for (S)");
* **coefficients**: from m on, the model no longer moves by more than ``pred_band`` (0.5)
  of the terminal S: RMS over the data of (ŷ_m − ŷ_N) ≤ 0.5·S_N.  Coefficients of
  correlated terms trade off against each other without changing the model, so a band on
  each coefficient would measure collinearity rather than saturation; the prediction band is
  scale-free (in units of the noise) and about independent of N once N is well above the
  saturation size.

The saturation size is the larger of the two.  It depends on the order of the points, so
PSR is repeated over several random orders and the median is reported.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sim.errors import InputError

__all__ = ["PSRSummary", "PSRTrace", "progressive_regression", "psr_saturation"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True, eq=False)
class PSRTrace:
    """One PSR run.

    Attributes
    ----------
    sizes
        Number of points m of each step [-].
    S
        Mean standard error at each step [unit of the response].
    coef
        Coefficients (constant first, then the terms) at each step, shape (steps, k).
    pred_shift
        RMS over all N points of ŷ_m − ŷ_N [unit of the response].
    n_sat_S, n_sat_coef
        Saturation sizes by the S band and by the prediction band [-].
    """

    sizes: IntArray
    S: FloatArray
    coef: FloatArray
    pred_shift: FloatArray
    n_sat_S: int
    n_sat_coef: int

    @property
    def n_sat(self) -> int:
        """Saturation size: the larger of the two criteria [-]."""
        return max(self.n_sat_S, self.n_sat_coef)


def _first_stable(sizes: IntArray, ok: npt.NDArray[np.bool_]) -> int:
    """Smallest size from which ``ok`` holds at every later step."""
    bad = np.flatnonzero(~ok)
    if bad.size == 0:
        return int(sizes[0])
    last = int(bad[-1])
    return int(sizes[last + 1]) if last + 1 < sizes.size else int(sizes[-1])


def progressive_regression(columns: Mapping[str, npt.ArrayLike], y: npt.ArrayLike,
                           terms: Sequence[str], order: npt.ArrayLike, *,
                           s_band: float = 0.10, pred_band: float = 0.5) -> PSRTrace:
    """PSR of a fixed model over the points taken in ``order``.

    Parameters
    ----------
    columns
        Regressors by name.
    y
        Response.
    terms
        Model terms (a constant is always added).
    order
        Permutation of the point indices.
    s_band
        Relative band around the terminal S [-].
    pred_band
        Band on the model's movement, in units of the terminal S [-].

    Returns
    -------
    PSRTrace
    """
    yy = np.asarray(y, dtype=np.float64).ravel()
    idx = np.asarray(order, dtype=np.int64).ravel()
    n = yy.size
    if idx.size != n or np.unique(idx).size != n:
        raise InputError("order must be a permutation of the points", field="order")
    for t in terms:
        if t not in columns:
            raise InputError(f"unknown term {t!r} (known: {', '.join(columns)})", field="terms")
    cols = [np.asarray(columns[t], dtype=np.float64).ravel() for t in terms]
    for t, c in zip(terms, cols, strict=True):
        if c.size != n:
            raise InputError(f"{c.size} values, expected {n}", field=f"columns.{t}")
    X = np.column_stack([np.ones(n), *cols])
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(yy))):
        # a NaN made every S NaN, and the trace read "never saturates" (a user pass)
        raise InputError("non-finite values in the regression", field="y")
    k = X.shape[1]
    if n < k + 3:
        raise InputError(f"PSR needs at least {k + 3} points", field="y")
    scale = np.sqrt(np.mean(X**2, axis=0))
    scale[scale == 0] = 1.0
    Xs = (X / scale)[idx]
    ys = yy[idx]
    sizes = np.arange(k + 2, n + 1, dtype=np.int64)
    S = np.empty(sizes.size)
    coef = np.empty((sizes.size, k))
    for i, m in enumerate(sizes):
        b, *_ = np.linalg.lstsq(Xs[:m], ys[:m], rcond=None)
        r = ys[:m] - Xs[:m] @ b
        S[i] = np.sqrt(float(r @ r) / (m - k))
        coef[i] = b
    pred = Xs @ coef.T                     # (n, steps): every step's model on all points
    shift = np.sqrt(np.mean((pred - pred[:, -1:]) ** 2, axis=0))
    s_ok = np.abs(S / S[-1] - 1.0) <= s_band
    c_ok = shift <= pred_band * S[-1]
    return PSRTrace(sizes=sizes, S=S, coef=coef / scale, pred_shift=shift,
                    n_sat_S=_first_stable(sizes, s_ok), n_sat_coef=_first_stable(sizes, c_ok))


@dataclass(frozen=True, eq=False)
class PSRSummary:
    """PSR over several random orders.

    Attributes
    ----------
    n_sat
        Saturation size of each order [-].
    median, p90
        Median and 90th percentile of ``n_sat`` [-].
    n_points
        Size of the data set [-].
    traces
        The individual runs.
    """

    n_sat: IntArray
    median: float
    p90: float
    n_points: int
    traces: tuple[PSRTrace, ...]


def psr_saturation(columns: Mapping[str, npt.ArrayLike], y: npt.ArrayLike,
                   terms: Sequence[str], *, orders: int = 20,
                   seed: int | np.random.Generator = 0, s_band: float = 0.10,
                   pred_band: float = 0.5) -> PSRSummary:
    """PSR repeated over ``orders`` random orders of the points (seeded).

    Returns
    -------
    PSRSummary
        Median and 90th percentile of the saturation size.
    """
    if orders < 1:
        raise InputError("at least one order", field="orders")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    n = int(np.asarray(y).size)
    traces = tuple(progressive_regression(columns, y, terms, rng.permutation(n),
                                          s_band=s_band, pred_band=pred_band)
                   for _ in range(orders))
    sat = np.array([t.n_sat for t in traces], dtype=np.int64)
    return PSRSummary(n_sat=sat, median=float(np.median(sat)),
                      p90=float(np.percentile(sat, 90)), n_points=n, traces=traces)
