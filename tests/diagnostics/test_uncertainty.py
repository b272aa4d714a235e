"""GUM propagation (:mod:`diagnostics.uncertainty`) against hand calculations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.quantity import Quantity
from diagnostics.uncertainty import delta_method, propagate


def test_delta_method_of_a_linear_model_is_the_gum_sum_of_squares() -> None:
    # y = 2a − 3b with u(a) = 0.1, u(b) = 0.2 (GUM §5.1.2, uncorrelated inputs):
    # u(y) = √((2·0.1)² + (3·0.2)²) = √(0.04 + 0.36) = 0.63246; contributions 10 % and 90 %
    inputs = {"a": Quantity(5.0, 0.1), "b": Quantity(1.0, 0.2)}
    est = delta_method(lambda x: 2.0 * x["a"] - 3.0 * x["b"], inputs, quantity="y", unit="1")
    assert est.value == pytest.approx(7.0)
    assert est.u == pytest.approx(0.63246, rel=1e-5, abs=0)
    assert est.sensitivities == pytest.approx({"a": 2.0, "b": -3.0}, rel=1e-8, abs=0)
    assert est.contributions == pytest.approx({"a": 0.1, "b": 0.9}, rel=1e-8, abs=0)
    assert (est.low, est.high) == pytest.approx((7.0 - 1.959964 * 0.63246,
                                                 7.0 + 1.959964 * 0.63246), rel=1e-5, abs=0)


def test_a_clearance_interval_stops_at_zero() -> None:
    # a clearance of 2 µm known to ±3 µm: value − 1.96·u = −3.9 µm is no clearance; with
    # the physical bound 0 the interval runs from 0 (its upper end unchanged), for the
    # delta method as for "auto" where it keeps the delta result
    inputs = {"c": Quantity(2e-6, 3e-6)}
    for est in (delta_method(lambda x: np.asarray(x["c"]), inputs, quantity="cc", unit="m",
                             lower=0.0),
                propagate(lambda x: np.asarray(x["c"]), inputs, quantity="cc", unit="m",
                          method="delta", lower=0.0)):
        assert est.low == 0.0
        assert est.high == pytest.approx(2e-6 + 1.959964 * 3e-6, rel=1e-6, abs=0)
        assert est.u == pytest.approx(3e-6, rel=1e-8, abs=0)
    unbounded = delta_method(lambda x: np.asarray(x["c"]), inputs, quantity="cc", unit="m")
    assert unbounded.low == pytest.approx(2e-6 - 1.959964 * 3e-6, rel=1e-6, abs=0)
    assert math.isfinite(unbounded.low)
