"""The one rule of what is a number (:func:`sim.numbers.real_number`), and both its users
holding it: a rig's overrides and a record's bare readings."""

from __future__ import annotations

import numpy as np
import pytest

from sim.numbers import real_number


@pytest.mark.parametrize("value", [3, 2.5, np.float32(2.5), np.int64(3), np.array(2.5),
                                   np.float64("1e-9")])
def test_real_scalars_are_numbers(value: object) -> None:
    assert real_number(value) == pytest.approx(float(value), rel=1e-7)  # type: ignore[arg-type]


@pytest.mark.parametrize("value", [True, np.bool_(False), "60 um", None, [1.0],
                                   np.array([1.0, 2.0]), 1 + 2j, np.array(True)])
def test_others_are_not(value: object) -> None:
    assert real_number(value) is None


def test_overrides_and_readings_take_and_refuse_the_same() -> None:
    from diagnostics.measurement import _as_quantity
    from diagnostics.quantity import InstrumentClass
    from sim.errors import MeasurementError, ParameterError
    from sim.rigs.assembly import _number

    instrument = {"p1": InstrumentClass("transducer", 0.005, 0.0, "a test")}
    for good in (np.float32(1.2e6), np.array(1.2e6), 1200000):
        assert _number(good, "valve.cv") == pytest.approx(1.2e6)
        assert _as_quantity("p1", good, instrument).value == pytest.approx(1.2e6)  # type: ignore[arg-type]
    for bad in (True, "12 bar", np.array([1.0])):
        with pytest.raises(ParameterError):
            _number(bad, "valve.cv")
        with pytest.raises(MeasurementError):
            _as_quantity("p1", bad, instrument)  # type: ignore[arg-type]
