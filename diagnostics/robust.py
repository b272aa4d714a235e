"""Robust scatter: the normal-consistent median absolute deviation, and a least-squares
fit's covariance robust to residuals correlated within blocks (:func:`cluster_cov`).

σ̂ = 1.4826 · median|x − median(x)| (Rousseeuw & Croux, *J. Am. Stat. Assoc.* 88, 1993,
1273-1283: the factor 1/Φ⁻¹(3/4) makes it the standard deviation of Gaussian data), which
one wrong reading in a few cannot move — the trend fits, the level-shift test and the ZeMA
leak sizes read their scatter by it.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["MAD_TO_SIGMA", "cluster_cov", "mad_sigma"]

#: 1/Φ⁻¹(3/4): the MAD of Gaussian data times this is its standard deviation [-]
MAD_TO_SIGMA = 1.4826


def mad_sigma(x: npt.ArrayLike) -> float:
    """σ̂ = 1.4826·median|x − median(x)| [unit of ``x``]; 0 for no values."""
    a = np.asarray(x, dtype=float)
    if a.size == 0:
        return 0.0
    return MAD_TO_SIGMA * float(np.median(np.abs(a - np.median(a))))


def cluster_cov(jac: npt.NDArray[np.float64], resid: npt.NDArray[np.float64],
                sizes: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Cluster-robust (sandwich) covariance of a least-squares fit's parameters.

    cov = G/(G − 1) · (JᵀJ)⁻¹ [Σ_g (J_gᵀ r_g)(J_gᵀ r_g)ᵀ] (JᵀJ)⁻¹ over the G contiguous
    blocks of ``sizes`` samples (Liang & Zeger, *Biometrika* 73, 1986, 13-22; the G/(G − 1)
    small-sample factor of Stata's CR1): residuals may be correlated in any way within a
    block, not between blocks.  A fitted model's systematic misfit (a solver's error well
    below the noise, a phase mis-timed by a sample) is smooth over a whole record's phase,
    and over thousands of samples the usual (JᵀJ)⁻¹·s² counts it as that many
    independent readings.

    Parameters
    ----------
    jac
        Jacobian of the residuals at the solution, n × k [residual unit per parameter].
    resid
        Residuals at the solution, n [-].
    sizes
        Samples per block, in order; they sum to n.
    """
    J = np.asarray(jac, dtype=float)
    r = np.asarray(resid, dtype=float)
    bounds = np.cumsum(np.asarray(sizes, dtype=int))[:-1]
    scores = np.array([Jg.T @ rg for Jg, rg in
                       zip(np.split(J, bounds), np.split(r, bounds), strict=True)])
    g = scores.shape[0]
    bread = np.linalg.inv(J.T @ J)
    meat = scores.T @ scores * (g / (g - 1.0) if g > 1 else 1.0)
    return np.asarray(bread @ meat @ bread, dtype=float)
