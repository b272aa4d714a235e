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
    from diagnostics.quantity import InstrumentClass
    from diagnostics.reading_checks import as_quantity
    from sim.errors import MeasurementError, ParameterError
    from sim.rigs.assembly import _number

    instrument = {"p1": InstrumentClass("transducer", 0.005, 0.0, "a test")}
    for good in (np.float32(1.2e6), np.array(1.2e6), 1200000):
        assert _number(good, "valve.cv") == pytest.approx(1.2e6)
        assert as_quantity("p1", good, instrument).value == pytest.approx(1.2e6)  # type: ignore[arg-type]
    for bad in (True, "12 bar", np.array([1.0])):
        with pytest.raises(ParameterError):
            _number(bad, "valve.cv")
        with pytest.raises(MeasurementError):
            as_quantity("p1", bad, instrument)  # type: ignore[arg-type]


@pytest.mark.parametrize(("value", "words"), [
    ("60 um", "got str '60 um'"), (None, "got NoneType None"), ([1.0], "got list [1.0]"),
    (10**400, "too large for a float"), (-(10**400), "too large for a float")])
def test_field_number_refuses_with_the_fields_error(value: object, words: str) -> None:
    """A string, a list or an int beyond the float range raised a bare TypeError or
    OverflowError (a library user's pass, a verification pass): now the given error class,
    naming the field."""
    from sim.errors import MeasurementError
    from sim.numbers import field_number

    with pytest.raises(MeasurementError) as caught:
        field_number(value, "records[0].p1", error=MeasurementError)
    assert caught.value.field == "records[0].p1" and words in caught.value.message
    assert real_number(value) is None


def test_field_number_keeps_numbers_and_refuses_non_finite_on_request() -> None:
    from sim.errors import InputError
    from sim.numbers import field_number

    assert field_number(np.float32(2.5), "x") == 2.5 and field_number(10**300, "x") == 1e300
    assert np.isnan(field_number(float("nan"), "x"))
    with pytest.raises(InputError) as caught:
        field_number(float("inf"), "t_max", finite=True)
    assert caught.value.field == "t_max" and "finite" in caught.value.message
