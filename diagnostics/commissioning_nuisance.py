"""Commissioning intervals with the parameters the records leave open integrated, not
linearised.

:func:`diagnostics.commissioning.commission` fits ``z = ln(θ/θ₀)`` and states each pinned
parameter's 95 % interval from the Laplace approximation, ``ẑ_j ± 1.96·√C_jj``: the
posterior is taken as Gaussian in z, and the parameters the records do not pin (their
posterior still about their prior) enter a pinned one's interval only through the
linearised correlation.  That is wrong where a pinned parameter takes up an open one's
error through a law that is not linear in z: the force balance sees the seal friction
``Fu + Kf·v`` (paper 002 eqs. 35-38), so at one pump speed the viscous coefficient Kf is
open and Fu's estimate carries ``Kf₀·(e^{z_Kf} − 1)·v``, skewed upward.  With the as-built
Kf one prior σ off the document's, Fu's Laplace interval held the truth in 88 % of 997
seeds where 95 % was stated (``make accuracy``'s commissioning suite).

Here the open parameters ``n`` are integrated over their Laplace posterior ``N(ẑ_n,
C_nn)``: on a grid of Gauss-Hermite nodes (:data:`NODES` on each, a tensor grid mapped
through the Cholesky factor of ``C_nn``) the pinned parameters ``p`` are fitted again with
the open ones held there (:func:`~diagnostics.prior_fit.fit_with_prior`, the fit of
commissioning itself, started from the linear prediction ``ẑ_p + C_pn C_nn⁻¹ Δz_n``),
giving a conditional mean ``m_p`` and the conditional covariance ``(J_pᵀJ_p +
diag(1/s_p²))⁻¹``; both are interpolated between the nodes (Lagrange polynomials), the
open parameters taken at :data:`_SAMPLES` points of their distribution (its quantiles for
one open parameter, fixed-seed draws for more), and the pinned parameter's 95 % interval
is the 2.5 % and 97.5 % quantiles of the resulting mixture. (The nodes' mixture alone,
with the quadrature weights, is a few narrow spikes where a pinned parameter is precise
given the open ones: its tail quantile fell on one spike or another with the number of
nodes.) With a law linear in z the mixture is the Laplace Gaussian again. Where the rig
has no steady point at a node, a 3-node grid is tried, then the Laplace interval stands.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt
from scipy.optimize import brentq
from scipy.special import ndtr, ndtri

from diagnostics.prior_fit import fit_with_prior
from sim.errors import SimulationError

__all__ = ["NODES", "marginal_intervals"]

Arr = npt.NDArray[np.float64]

#: Gauss-Hermite nodes on each open parameter, where the pinned ones are fitted again;
#: between them the conditional means are their degree-4 Lagrange interpolant [-]
NODES = 5
#: draws of the open parameters through the interpolated conditional means [-]
_SAMPLES = 2000


def _quantile(means: Arr, sds: Arr, q: float) -> float:
    """The ``q`` quantile of the equal-weight Gaussian mixture of ``means`` and ``sds``."""
    lo = float(np.min(means - 8.0 * sds))
    hi = float(np.max(means + 8.0 * sds))
    return float(brentq(lambda x: float(np.mean(ndtr((x - means) / sds))) - q, lo, hi,
                        xtol=1e-10))


def _lagrange(nodes: Arr, x: Arr) -> Arr:
    """Lagrange basis of ``nodes`` at the points ``x``: shape (x.size, nodes.size)."""
    out = np.ones((x.size, nodes.size))
    for i, xi in enumerate(nodes):
        for j, xj in enumerate(nodes):
            if j != i:
                out[:, i] *= (x - xj) / (xi - xj)
    return out


def _conditionals(residuals: Callable[[Arr], Arr], z: Arr, s: Arr, cov: Arr,
                  keep: list[int], open_: list[int], nodes: Arr, max_iterations: int
                  ) -> tuple[Arr, Arr] | None:
    """Conditional means and standard deviations of the pinned parameters at every node
    of the grid (shape (nodes**len(open_), len(keep))), or None where the rig has no
    steady point at one of them."""
    c_nn = cov[np.ix_(open_, open_)]
    chol = np.linalg.cholesky(c_nn + 1e-15 * np.eye(len(open_)))
    gain = cov[np.ix_(keep, open_)] @ np.linalg.inv(c_nn)  # linear prediction of the pinned
    means, sds = [], []
    for combo in itertools.product(range(nodes.size), repeat=len(open_)):
        shift = chol @ nodes[list(combo)]
        start = z.copy()
        start[open_] = z[open_] + shift
        start[keep] = z[keep] + gain @ shift
        try:
            zc, _, jac, _ = fit_with_prior(residuals, s, start, keep, max_iterations)
        except SimulationError:
            return None
        cond = np.linalg.inv(jac.T @ jac + np.diag(1.0 / s[keep] ** 2))
        means.append(zc[keep])
        sds.append(np.sqrt(np.clip(np.diag(cond), 1e-30, None)))
    return np.array(means), np.array(sds)


def marginal_intervals(residuals: Callable[[Arr], Arr], z: Arr, s: Arr, cov: Arr,
                       pinned: Sequence[bool], *, max_iterations: int = 30
                       ) -> dict[int, tuple[float, float]]:
    """The 95 % interval in z of each pinned parameter (index → (low, high)) with the open
    parameters integrated (module docstring); empty where none is open, none pinned, or
    the rig has no steady point at a node of either grid (the Laplace intervals stand).

    Parameters
    ----------
    residuals
        Whitened data residuals of the records at z [-].
    z
        The fit (posterior mode) in ln(θ/θ₀) [-].
    s
        Prior standard deviations of z [-].
    cov
        Laplace posterior covariance of z [-].
    pinned
        Whether each parameter is pinned down by the records.
    max_iterations
        Iteration limit of each re-fit (:func:`~diagnostics.prior_fit.fit_with_prior`) [-].
    """
    keep = [j for j, p in enumerate(pinned) if p]
    open_ = [k for k, p in enumerate(pinned) if not p]
    if not keep or not open_:
        return {}
    for n_nodes in (NODES, 3):
        nodes = np.polynomial.hermite_e.hermegauss(n_nodes)[0]  # N(0, 1) nodes
        got = _conditionals(residuals, z, s, cov, keep, open_, nodes, max_iterations)
        if got is not None:
            break
    else:
        return {}
    means, sds = got
    # the open parameters' standard-normal coordinates: one open parameter at the
    # quantiles of N(0, 1) (stratified), more drawn with a fixed seed (the same every call)
    x = (ndtri((np.arange(_SAMPLES) + 0.5) / _SAMPLES)[:, None] if len(open_) == 1 else
         np.random.default_rng(0).standard_normal((_SAMPLES, len(open_))))
    basis = np.ones((_SAMPLES, means.shape[0]))
    for d in range(len(open_)):  # tensor-product Lagrange weights of the grid's nodes
        ld = _lagrange(nodes, x[:, d])
        for g, combo in enumerate(itertools.product(range(nodes.size), repeat=len(open_))):
            basis[:, g] *= ld[:, combo[d]]
    m = basis @ means
    sd = np.clip(basis @ sds, 1e-12, None)
    return {j: (_quantile(m[:, c], sd[:, c], 0.025), _quantile(m[:, c], sd[:, c], 0.975))
            for c, j in enumerate(keep)}
