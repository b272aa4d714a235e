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
