"""Numbers typed into the console's fields (:mod:`app.console.numbers`): a decimal comma
and digit groups read as engineers write them; an ambiguous comma refused, naming the
field."""

from __future__ import annotations

import math

import pytest

from app.console.numbers import decimal_text, form_number
from sim.errors import InputError


@pytest.mark.parametrize(("typed", "value"), [
    ("4.2", 4.2), ("4,2", 4.2), (" -0,5e-3 ", -0.5e-3), ("0,500", 0.5), ("12,5", 12.5),
    ("1 500", 1500.0), ("1\u202f500,25", 1500.25), ("1'500", 1500.0), ("1500", 1500.0),
    ("2,1e3", 2100.0), ("+7", 7.0)])
def test_a_decimal_comma_and_digit_groups_are_read(typed: str, value: float) -> None:
    assert form_number(typed, field="load") == pytest.approx(value, rel=1e-15)


@pytest.mark.parametrize("typed", ["1,500", "-12,000", "999,999"])
def test_a_comma_before_three_digits_is_asked_about(typed: str) -> None:
    with pytest.raises(InputError) as caught:
        decimal_text(typed, field="displacement")
    whole, part = typed.split(",")
    assert caught.value.field == "displacement"
    assert f"{whole}.{part}" in caught.value.message and f"{whole}{part}" in caught.value.message


@pytest.mark.parametrize("typed", ["1,2,3", "1,500.5", "four", "4 ,2", "nan", "inf", "1e999",
                                   "2 1", "1'5"])
def test_what_is_not_one_number_is_refused_naming_the_field(typed: str) -> None:
    with pytest.raises(InputError) as caught:
        form_number(typed, field="condition.load")
    assert caught.value.field == "condition.load" and typed.strip() in caught.value.message


def test_blank_stays_blank_and_points_are_untouched() -> None:
    assert decimal_text("  ", field="x") == ""
    assert decimal_text("1,500.5", field="x") == "1,500.5"  # left to the number check
    assert math.isclose(form_number("1.500", field="x"), 1.5)  # a point is a point
