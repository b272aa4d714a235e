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


def test_the_cluster_sandwich_of_a_mean_by_hand() -> None:
    """A mean (intercept-only model, J = 1) fitted to 6 samples in blocks of 2, 1 and 3
    with residuals 1, 1 | −2 | 0.5, −0.25, −0.25 (they sum to 0, as a mean's do): the
    block scores are the blocks' residual sums 2, −2, 0, so CR1 = G/(G − 1)·Σ s_g²/n² =
    3/2 · 8/36 = 1/3.  Block bounds shifted by one (blocks of 3, 3, 0: scores 0, 0) gave
    0, and without the small-sample factor it read 2/9 (a mutation review)."""
    from diagnostics.robust import cluster_cov

    J = np.ones((6, 1))
    r = np.array([1.0, 1.0, -2.0, 0.5, -0.25, -0.25])
    assert cluster_cov(J, r, [2, 1, 3])[0, 0] == pytest.approx(1.0 / 3.0, rel=1e-12)


def test_single_sample_blocks_give_the_usual_variance_of_a_mean() -> None:
    """With one sample per block the errors are taken as independent: for a mean, CR1 is
    n/(n − 1)·Σr²/n² = s²/n, the textbook variance of a sample mean (s² with n − 1)."""
    from diagnostics.robust import cluster_cov

    y = np.random.default_rng(3).normal(2.0, 0.7, 25)
    r = y - y.mean()
    cov = cluster_cov(np.ones((y.size, 1)), r, [1] * y.size)
    assert cov[0, 0] == pytest.approx(np.var(y, ddof=1) / y.size, rel=1e-12)
