"""The least-squares pieces of the discrepancy selection (:mod:`~diagnostics.discrepancy.
selection`) and the pump re-fit (:mod:`~diagnostics.discrepancy.pump_refit`): columns
scaled to unit RMS, Newey-West (HAC) coefficient covariance, BIC, linear dependence on a
test design, the RMS a column adds beyond the others, and moving-block bootstrap rows.

Newey & West (1987) with the Bartlett kernel; BIC after Schwarz (1978) for Gaussian
residuals, ``n·ln(RSS/n) + k·ln n``.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = ["DEPENDENT", "bic", "hac_cov", "in_span", "moving_blocks", "scaled_columns",
           "unique_rms"]

Arr = npt.NDArray[np.float64]

#: relative residual norm after projection below which a column lies in a span [-]
DEPENDENT = 1e-3


def scaled_columns(cols: dict[str, Arr]) -> tuple[list[str], Arr, Arr]:
    """The columns' names, the columns divided by their RMS (a zero column kept as it
    is), and those RMS values [column unit]."""
    names = list(cols)
    if not names:
        return [], np.zeros((0, 0)), np.zeros(0)
    X = np.column_stack([cols[n] for n in names])
    scale = np.sqrt(np.mean(X * X, axis=0))
    scale[scale == 0] = 1.0
    return names, X / scale, scale


def hac_cov(X: Arr, resid: Arr, lags: int) -> Arr:
    """Newey-West covariance of OLS coefficients (Bartlett kernel); ``lags`` = 0 gives
    White's (HC0)."""
    n = X.shape[0]
    xtx_inv = np.linalg.pinv(X.T @ X)
    u = X * resid[:, None]
    S = u.T @ u
    for lag in range(1, min(lags, n - 1) + 1):
        w = 1.0 - lag / (lags + 1.0)
        G = u[lag:].T @ u[:-lag]
        S += w * (G + G.T)
    return np.asarray(xtx_inv @ S @ xtx_inv, dtype=float)


def bic(rss: float, n: int, k: int) -> float:
    """BIC of a least-squares fit of ``k`` coefficients to ``n`` samples [-]."""
    return n * math.log(max(rss, 1e-300) / n) + k * math.log(n)


def in_span(B: Arr, c: Arr) -> bool:
    """Whether column ``c`` lies (to :data:`DEPENDENT`) in the span of ``B``'s columns."""
    if B.shape[1] == 0:
        return bool(np.linalg.norm(c) == 0)
    coef, *_ = np.linalg.lstsq(B, c, rcond=None)
    return bool(np.linalg.norm(c - B @ coef) < DEPENDENT * np.linalg.norm(c))


def unique_rms(X: Arr, k: int, coef: float) -> float:
    """RMS of what column ``k`` of ``X`` adds to the fit beyond the other columns,
    ``|coef|·‖M x_k‖/√n`` with ``M`` the projection off them (the RMS of the RSS increase
    when the term is dropped and the rest re-fitted) [units of ``X @ coef``]."""
    others = np.delete(X, k, axis=1)
    proj, *_ = np.linalg.lstsq(others, X[:, k], rcond=None)
    rest = X[:, k] - others @ proj
    return abs(coef) * float(np.sqrt(np.mean(rest * rest)))


def moving_blocks(n: int, size: int, rng: np.random.Generator) -> npt.NDArray[np.int64]:
    """Row indices of a moving-block bootstrap resample: blocks of ``size`` consecutive
    rows from random starts, ``n`` rows in all."""
    starts = rng.integers(0, max(n - size, 1), size=math.ceil(n / size))
    return np.concatenate([np.arange(s, min(s + size, n)) for s in starts])[:n]
