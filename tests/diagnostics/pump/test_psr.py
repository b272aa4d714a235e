"""Progressively sequenced regression: traces and saturation sizes."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.pump import progressive_regression, psr_saturation
from sim.errors import InputError


def _data(n: int, sigma: float, seed: int = 0) -> tuple[dict[str, np.ndarray], np.ndarray]:
    rng = np.random.default_rng(seed)
    cols = {"x": rng.uniform(0, 1, n), "z": rng.uniform(0, 1, n)}
    y = 1.0 + 2.0 * cols["x"] - 0.5 * cols["z"] + sigma * rng.standard_normal(n)
    return cols, y


def test_trace_ends_at_the_full_fit_and_the_noise_level() -> None:
    cols, y = _data(300, 0.1)
    tr = progressive_regression(cols, y, ("x", "z"), np.arange(300))
    assert tr.sizes[0] == 5 and tr.sizes[-1] == 300
    assert tr.S[-1] == pytest.approx(0.1, rel=0.15)
    np.testing.assert_allclose(tr.coef[-1], [1.0, 2.0, -0.5], atol=0.1)
    assert tr.pred_shift[-1] == 0.0
    assert tr.sizes[0] <= tr.n_sat <= 300


def test_saturation_does_not_grow_with_the_data_set() -> None:
    small = psr_saturation(*_data(200, 0.1, 1), ("x", "z"), orders=15, seed=2)
    large = psr_saturation(*_data(800, 0.1, 1), ("x", "z"), orders=15, seed=2)
    assert small.median < 200 and large.median < 200
    assert large.median < 3 * small.median


def test_a_missing_term_raises_the_terminal_s() -> None:
    cols, y = _data(300, 0.05, 3)
    full = psr_saturation(cols, y, ("x", "z"), orders=5, seed=1)
    short = psr_saturation(cols, y, ("x",), orders=5, seed=1)
    assert short.traces[0].S[-1] > 1.5 * full.traces[0].S[-1]


def test_order_must_be_a_permutation() -> None:
    cols, y = _data(50, 0.1)
    with pytest.raises(InputError) as e:
        progressive_regression(cols, y, ("x",), np.zeros(50))
    assert e.value.field == "order"


def test_bad_regressions_are_refused_with_the_field() -> None:
    x = np.linspace(0.0, 1.0, 40)
    y = 2.0 + 3.0 * x
    order = np.arange(40)
    bad_y = y.copy()
    bad_y[7] = np.nan  # was a trace of NaN S reading "never saturates"
    for columns, yy, terms, field in (({"x": x}, bad_y, ["x"], "y"),
                                      ({"x": x}, y, ["nope"], "terms"),  # was a KeyError
                                      ({"x": x[:30]}, y, ["x"], "columns.x")):
        with pytest.raises(InputError) as e:
            progressive_regression(columns, yy, terms, order)
        assert e.value.field == field
