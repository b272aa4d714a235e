"""Ordinary least squares with the figures of paper 001 §2.6, and best-subset selection.

Figures of merit of a fitted model (n points, k coefficients including the constant):

* **S**, the mean standard error [unit of the response]: ``S = √(SSE/(n − k))``
  (paper 001 §2.6: "the mean sum of squares of the difference between experimentally
  determined flow losses and the flow losses predicted by the model", in the response's
  units; the root of the residual mean square);
* **R²** = 1 − SSE/SST;
* **AIC** = n·ln(SSE/n) + 2k (Gaussian likelihood up to a constant), **BIC** with k·ln n;
* **VIF** of each non-constant column: 1/(1 − R²ⱼ) of column j on the others and a constant.

Best subsets (paper 001 §3.1): every subset of at most ``max_terms`` candidates is fitted
together with the forced terms; the model with the lowest AIC is chosen — the project's
rule: paper 001 chose its best 4- and 5-term models by R² and S, and used AIC and VIF to
screen out collinear ones.  With ``signs``,
a model in which a term with a definite physical sign (a loss that must reduce flow or add
torque) gets the opposite sign is not admissible, like the sign checks of DISCREPANCY.md
step 5; paper 001 does not say that it applied such a check.  VIF is reported
for every model.  Paper 001 also screened out models with high VIF; the project's prototype
(DISCREPANCY.md) found that a VIF > 10 filter removes physically real terms (√Δp and Δp
correlate at 0.99 over 20-250 bar), so the screen is optional (``max_vif``) and off by
default.  Columns are scaled to unit RMS before solving; coefficients are reported in the
columns' own units.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sim.errors import InputError

__all__ = ["RegressionModel", "SubsetSelection", "best_subset", "fit_ols", "vif"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class RegressionModel:
    """An OLS fit.

    Attributes
    ----------
    terms
        Column names, without the constant.
    intercept, intercept_se
        Constant β₀ and its standard error [unit of the response].
    coef, se
        Coefficients of ``terms`` and standard errors [response unit / column unit].
    n
        Number of points.
    S, r2, aic, bic
        Figures of merit (module doc).
    vif
        ``{term: VIF}`` [-] (NaN for a single column).
    """

    terms: tuple[str, ...]
    intercept: float
    intercept_se: float
    coef: FloatArray
    se: FloatArray
    n: int
    S: float
    r2: float
    aic: float
    bic: float
    vif: dict[str, float]

    @property
    def k(self) -> int:
        """Number of fitted coefficients including the constant."""
        return len(self.terms) + 1

    @property
    def max_vif(self) -> float:
        """Largest VIF of the model [-]."""
        vals = [v for v in self.vif.values() if math.isfinite(v)]
        return max(vals) if vals else math.nan

    def coefficient(self, term: str) -> float:
        """The coefficient of ``term``."""
        return float(self.coef[self.terms.index(term)])

    def predict(self, columns: Mapping[str, npt.ArrayLike]) -> FloatArray:
        """Response predicted from the model's columns."""
        out = np.full(np.shape(columns[self.terms[0]]) if self.terms else (), self.intercept)
        for t, b in zip(self.terms, self.coef, strict=True):
            out = out + b * np.asarray(columns[t], dtype=np.float64)
        return np.asarray(out, dtype=np.float64)


def vif(X: npt.ArrayLike) -> FloatArray:
    """Variance inflation factors of the columns of ``X`` (no constant column) [-].

    ``VIFⱼ = 1/(1 − R²ⱼ)`` with R²ⱼ of column j regressed on the others and a constant,
    computed as the diagonal of the inverse correlation matrix.  NaN for a single column;
    inf for an exactly collinear set.
    """
    A = np.asarray(X, dtype=np.float64)
    if A.ndim != 2:
        raise InputError("X must be 2-D", field="X")
    if A.shape[1] < 2:
        return np.full(A.shape[1], math.nan)
    C = np.corrcoef(A, rowvar=False)
    try:
        inv = np.linalg.inv(C)
    except np.linalg.LinAlgError:
        return np.full(A.shape[1], math.inf)
    d = np.diag(inv)
    return np.where(d > 0, d, math.inf)


def _solve(Xs: FloatArray, y: FloatArray) -> tuple[FloatArray, float]:
    sol, *_ = np.linalg.lstsq(Xs, y, rcond=None)
    beta = np.asarray(sol, dtype=np.float64)
    r = y - Xs @ beta
    return beta, float(r @ r)


def fit_ols(columns: Mapping[str, npt.ArrayLike], y: npt.ArrayLike,
            terms: Sequence[str]) -> RegressionModel:
    """OLS of ``y`` on a constant and the named ``columns``.

    Raises
    ------
    InputError
        Fewer points than coefficients + 1 (field ``y``), unknown term, non-finite data.
    """
    yy = np.asarray(y, dtype=np.float64).ravel()
    n = yy.size
    names = tuple(terms)
    for t in names:
        if t not in columns:
            raise InputError(f"unknown term {t!r}", field="terms")
    k = len(names) + 1
    if n <= k:
        raise InputError(f"{n} points cannot fit {k} coefficients with an error estimate",
                         field="y")
    cols = [np.asarray(columns[t], dtype=np.float64).ravel() for t in names]
    X = np.column_stack([np.ones(n), *cols]) if cols else np.ones((n, 1))
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(yy))):
        raise InputError("non-finite values in the regression", field="y")
    scale = np.sqrt(np.mean(X**2, axis=0))
    scale[scale == 0] = 1.0
    Xs = X / scale
    beta_s, sse = _solve(Xs, yy)
    beta = beta_s / scale
    dof = n - k
    s2 = sse / dof
    cov_s = s2 * np.linalg.pinv(Xs.T @ Xs)
    se = np.sqrt(np.maximum(np.diag(cov_s), 0.0)) / scale
    sst = float(np.sum((yy - yy.mean()) ** 2))
    sse_pos = max(sse, 1e-300)
    v = vif(X[:, 1:]) if cols else np.zeros(0)
    return RegressionModel(
        terms=names, intercept=float(beta[0]), intercept_se=float(se[0]),
        coef=beta[1:], se=se[1:], n=n, S=math.sqrt(s2),
        r2=1.0 - sse / sst if sst > 0 else math.nan,
        aic=n * math.log(sse_pos / n) + 2 * k, bic=n * math.log(sse_pos / n) + k * math.log(n),
        vif={t: float(x) for t, x in zip(names, v, strict=True)},
    )


@dataclass(frozen=True, eq=False)
class SubsetSelection:
    """Result of :func:`best_subset`.

    Attributes
    ----------
    best
        The chosen model (lowest AIC among the admissible subsets).
    ranking
        All admissible models, lowest AIC first.
    screened_out
        Number of subsets removed by the VIF screen.
    wrong_sign
        Number of subsets removed because a coefficient had the wrong physical sign.
    """

    best: RegressionModel
    ranking: tuple[RegressionModel, ...]
    screened_out: int
    wrong_sign: int = 0

    def runners_up(self, delta_aic: float = 2.0) -> tuple[RegressionModel, ...]:
        """Other models within ``delta_aic`` of the best (competing explanations)."""
        return tuple(m for m in self.ranking[1:] if m.aic - self.best.aic < delta_aic)


def best_subset(columns: Mapping[str, npt.ArrayLike], y: npt.ArrayLike, *,
                forced: Sequence[str] = (), candidates: Sequence[str] | None = None,
                max_terms: int = 4, max_vif: float | None = None,
                signs: Mapping[str, int] | None = None) -> SubsetSelection:
    """Best-subset regression screened by AIC (and optionally VIF).

    Parameters
    ----------
    columns
        Candidate regressors by name (e.g. from :func:`diagnostics.pump.terms.
        design_columns`).
    y
        Response.
    forced
        Terms in every model (displacement, ideal torque) besides the constant.
    candidates
        Terms to choose from (default: every column not forced).
    max_terms
        Largest number of candidates added to the forced terms [-].
    max_vif
        If given, subsets whose largest VIF exceeds it are not admissible (paper 001's
        screen; see module doc for why it is off by default).
    signs
        ``{term: ±1}``: required sign of a term's coefficient (e.g.
        :func:`diagnostics.pump.terms.expected_signs`); ``None``: no sign check.

    Returns
    -------
    SubsetSelection
    """
    forced_t = tuple(forced)
    cand = tuple(c for c in (candidates if candidates is not None else columns)
                 if c not in forced_t)
    if max_terms < 0:
        raise InputError("max_terms must be ≥ 0", field="max_terms")
    sg = dict(signs) if signs is not None else {}
    models: list[RegressionModel] = []
    screened = 0
    wrong = 0
    for size in range(0, min(max_terms, len(cand)) + 1):
        for combo in itertools.combinations(cand, size):
            m = fit_ols(columns, y, forced_t + combo)
            if max_vif is not None and m.max_vif > max_vif:
                screened += 1
                continue
            if any(sg.get(t, 0) * b < 0 for t, b in zip(m.terms, m.coef, strict=True)):
                wrong += 1
                continue
            models.append(m)
    if not models:
        raise InputError("no subset passes the VIF screen and sign checks", field="max_vif")
    models.sort(key=lambda m: m.aic)
    return SubsetSelection(best=models[0], ranking=tuple(models), screened_out=screened,
                           wrong_sign=wrong)
