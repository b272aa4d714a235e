"""The pair fits' Laplace evidence (diagnostics.ranking.laplace_evidence) inverts its 2×2
Gauss-Newton Hessian in closed form (issue 9): exact against rational arithmetic, near
collinear pairs included, and the hand values of an orthogonal pair."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from diagnostics.ranking import laplace_evidence


def _exact(jac: np.ndarray) -> tuple[list[float], float]:
    """Variances and ln det of (JᵀJ + εI)⁻¹ in exact rational arithmetic."""
    rows = [[Fraction(float(x)) for x in r] for r in jac]
    h00 = sum(r[0] * r[0] for r in rows)
    h11 = sum(r[1] * r[1] for r in rows)
    h01 = sum(r[0] * r[1] for r in rows)
    eps = Fraction(1e-12) * max(h00 + h11, Fraction(1e-30))
    a, d = h00 + eps, h11 + eps
    det = a * d - h01 * h01
    return [float(d / det), float(a / det)], -math.log(det)


def test_covariance_exact_also_for_near_collinear_pairs() -> None:
    rng = np.random.default_rng(11)
    z, zl, zu = np.array([0.3, 0.6]), np.zeros(2), np.ones(2)
    for k in range(300):
        jac = rng.normal(size=(int(rng.integers(2, 9)), 2)) * 10 ** rng.uniform(-3, 3, 2)
        if k % 2:  # the second column nearly a multiple of the first: a ridge
            jac[:, 1] = jac[:, 0] * rng.uniform(0.5, 2.0) * (
                1.0 + 10 ** rng.uniform(-12, -3) * rng.normal(size=jac.shape[0]))
        var, logdet = _exact(jac)
        _, cov, sd = laplace_evidence(2.0, jac, z, zl, zu)
        np.testing.assert_allclose(np.diag(cov), var, rtol=1e-8)
        np.testing.assert_allclose(sd, np.sqrt(var), rtol=1e-8)
        # ln det enters ln Z as ½ ln det: the log evidence is exact too
        det_cov = cov[0, 0] * cov[1, 1] - cov[0, 1] * cov[1, 0]
        if k % 2 == 0:
            assert math.log(det_cov) == pytest.approx(logdet, abs=1e-8)


def test_orthogonal_pair_by_hand() -> None:
    # J columns orthogonal: cov = diag(1/|J₀|², 1/|J₁|²) (up to the 1e-12 regularisation);
    # an estimate in the middle of a wide prior: mass 1, ln Z = −χ²/2 + ln(2π σ₀σ₁ / V)
    jac = np.array([[2.0, 0.0], [0.0, 4.0], [0.0, 3.0]])
    z, zl, zu = np.array([5.0, 5.0]), np.zeros(2), np.full(2, 10.0)
    log_z, cov, sd = laplace_evidence(3.0, jac, z, zl, zu)
    np.testing.assert_allclose(sd, [0.5, 0.2], rtol=1e-10)
    assert cov[0, 1] == 0.0
    assert log_z == pytest.approx(-1.5 + math.log(2 * math.pi * 0.5 * 0.2 / 100.0), rel=1e-9)

