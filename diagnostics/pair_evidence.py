"""Evidence of a two-parameter hypothesis from its fit (:mod:`diagnostics.ranking`).

The marginal likelihood ``Z = (1/V) ∫ exp(−χ²(z)/2) dz`` over the pair's uniform prior box
``[zl, zu]`` in fitting coordinates, two ways:

* :func:`laplace_evidence` — the Laplace approximation at the estimate (Gauss-Newton
  Hessian ``JᵀJ``), with the posterior mass truncated at the bounds (MacKay 2003,
  *Information Theory, Inference, and Learning Algorithms*, ch. 27-28);
* :func:`profile_evidence` — where one axis is weak (the likelihood is flat along it), a
  trapezoid along the profile of that axis with a bound-truncated Laplace width across.

Both cap the Occam factor at 0: a flat likelihood cannot beat its prior.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy.special import ndtr

__all__ = ["laplace_evidence", "profile_evidence"]

Arr = npt.NDArray[np.float64]


def laplace_evidence(cost: float, jac: Arr, z: Arr, zl: Arr, zu: Arr
                     ) -> tuple[float, Arr, Arr]:
    """ln Z of a pair by the Laplace approximation at the estimate ``z``, with the posterior
    mass truncated at the bounds ``zl``, ``zu``; also the covariance and standard deviations
    (a zero one replaced by the range) from the Gauss-Newton Hessian ``JᵀJ``.

    The Occam factor is capped at 0: a flat likelihood cannot beat its prior.
    """
    span = zu - zl
    h = jac.T @ jac
    # the regularised 2×2 Hessian inverted in closed form (positive definite: its
    # pseudo-inverse, without an SVD per fit); det(JᵀJ) by Cauchy-Binet, a sum of squared
    # 2×2 minors of J, so a near-collinear pair loses no digits to cancellation
    eps = 1e-12 * max(float(h[0, 0] + h[1, 1]), 1e-30)
    a, b, c, d = float(h[0, 0]) + eps, float(h[0, 1]), float(h[1, 0]), float(h[1, 1]) + eps
    minors = np.outer(jac[:, 0], jac[:, 1]) - np.outer(jac[:, 1], jac[:, 0])
    det = 0.5 * float(np.sum(minors * minors)) + eps * (a + d - 2.0 * eps) + eps * eps
    logdet = math.nan  # ln det cov
    if det > 0.0 and math.isfinite(det):
        cov: Arr = np.array([[d / det, -b / det], [-c / det, a / det]])
        logdet = -math.log(det)
    else:
        cov = np.asarray(np.linalg.pinv(np.array([[a, b], [c, d]])), dtype=np.float64)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    sd = np.where(sd > 0, sd, span)
    mass = float(np.prod(ndtr((zu - z) / sd) - ndtr((zl - z) / sd)))
    if not math.isfinite(logdet):
        logdet = float(np.sum(np.log(sd**2)))
    occam = math.log(2 * math.pi) + 0.5 * logdet + math.log(max(mass, 1e-300)) \
        - float(np.sum(np.log(span)))
    occam = min(occam, 0.0)  # a flat likelihood cannot beat its prior
    return -0.5 * cost + occam, cov, sd


def profile_evidence(grid: Arr, chi2: Arr, hss: Arr, zs: Arr, zl: Arr, zu: Arr, weak: int
                     ) -> float:
    """ln Z of a pair from its profile along the weak axis: at each ``grid`` point the
    profiled ``chi2``, the curvature ``hss`` (JᵀJ) and the strong coordinate ``zs``; a
    bound-truncated Laplace width across (capped at the prior), a trapezoid along."""
    strong = 1 - weak
    span = zu - zl
    logs = np.empty(grid.size)
    for k in range(grid.size):
        if hss[k] > 0:
            sd = 1.0 / math.sqrt(float(hss[k]))
            mass = float(ndtr((zu[strong] - zs[k]) / sd) - ndtr((zl[strong] - zs[k]) / sd))
            across = math.log(math.sqrt(2 * math.pi) * sd * max(mass, 1e-300) / span[strong])
        else:
            across = 0.0
        logs[k] = -0.5 * float(chi2[k]) + min(across, 0.0)
    top = float(logs.max())
    w = np.exp(logs - top)
    integral = float(np.sum(0.5 * (w[1:] + w[:-1]) * np.diff(grid))) / span[weak]
    return top + math.log(max(integral, 1e-300))
