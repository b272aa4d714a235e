"""The robust scatter the trends, the level-shift test and the ZeMA leak sizes read."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from diagnostics.robust import MAD_TO_SIGMA, mad_sigma


def test_mad_sigma_is_the_standard_deviation_of_gaussian_data() -> None:
    x = np.random.default_rng(1).normal(5.0, 2.0, 200_000)
    # the MAD's own standard error at n = 200,000 is 1.67·σ/√n ≈ 0.4 % of σ
    assert mad_sigma(x) == pytest.approx(2.0, rel=0.015)
    assert 1.0 / norm.ppf(0.75) == pytest.approx(MAD_TO_SIGMA, rel=1e-4)


def test_one_wrong_reading_does_not_move_it_and_no_readings_give_zero() -> None:
    x = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    # median 3, |x − 3| = 2, 1, 0, 1, 2: MAD 1
    assert mad_sigma(x) == pytest.approx(1.4826)
    assert mad_sigma(np.array([1.0, 2.0, 3.0, 4.0, 5e9])) == pytest.approx(1.4826)
    assert mad_sigma([]) == 0.0


def test_the_cluster_sandwich_counts_a_misfit_shared_within_blocks() -> None:
    """A line fitted to 40 blocks of 50 samples whose errors share an offset per block (as
    a re-fit's misfit is shared over a phase): the usual (JᵀJ)⁻¹·s² understates the
    spread of the fitted slope about 5×, the sandwich states it; on independent errors the
    two agree."""
    from diagnostics.robust import cluster_cov

    rng = np.random.default_rng(7)
    blocks, per = 40, 50
    x = rng.uniform(-1.0, 1.0, blocks)  # the regressor is constant within a block
    J = np.column_stack([np.ones(blocks * per), np.repeat(x, per)])
    for shared in (0.5, 0.0):
        slopes, sandwich, plain = [], [], []
        for _ in range(400):
            e = np.repeat(rng.normal(0.0, shared, blocks), per) + rng.normal(0.0, 1.0, J.shape[0])
            coef, *_ = np.linalg.lstsq(J, e, rcond=None)
            r = e - J @ coef
            slopes.append(coef[1])
            sandwich.append(cluster_cov(J, r, [per] * blocks)[1, 1])
            plain.append((np.linalg.inv(J.T @ J) * (r @ r) / (r.size - 2))[1, 1])
        truth = float(np.var(slopes))
        assert np.mean(sandwich) == pytest.approx(truth, rel=0.2), shared
        if shared:
            assert np.mean(plain) < truth / 4
        else:
            assert np.mean(plain) == pytest.approx(truth, rel=0.2)
