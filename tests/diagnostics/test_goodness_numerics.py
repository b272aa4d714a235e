"""The goodness-of-fit test's χ² tail and quantile (diagnostics.goodness) are the same
numbers as scipy.stats.chi2's, which they replace on the hot path (issue 9)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from diagnostics.goodness import _p_value, chi2_limit


@pytest.mark.parametrize("dof", [1, 2, 3, 5, 7, 12, 30])
def test_tail_equals_scipy_stats(dof: int) -> None:
    xs = np.concatenate([np.random.default_rng(dof).uniform(0.0, 150.0, 100),
                         [0.0, 1e-300, 1e3]])
    for x in xs:
        assert _p_value(float(x), dof) == pytest.approx(float(chi2.sf(x, dof)), rel=1e-12,
                                                        abs=1e-300)
    assert _p_value(math.inf, dof) == 0.0
    assert _p_value(math.nan, dof) == 0.0


@pytest.mark.parametrize("dof", [1, 2, 4, 9, 25])
@pytest.mark.parametrize("level", [0.001, 0.01, 0.05])
def test_limit_equals_scipy_stats(dof: int, level: float) -> None:
    assert chi2_limit(level, dof) == pytest.approx(float(chi2.ppf(1.0 - level, dof)), rel=1e-12)
    # and it is the quantile: the tail beyond it is the level
    assert _p_value(chi2_limit(level, dof), dof) == pytest.approx(level, rel=1e-9)


def test_hand_values() -> None:
    # ν = 2: P(χ² ≥ x) = exp(−x/2) exactly; the 1 % limit is −2 ln 0.01 = 9.2103...
    assert _p_value(3.0, 2) == pytest.approx(math.exp(-1.5), rel=1e-13)
    assert chi2_limit(0.01, 2) == pytest.approx(-2.0 * math.log(0.01), rel=1e-12)
