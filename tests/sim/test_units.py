"""Unit spellings an engineer writes (sim/units.py)."""

from __future__ import annotations

import pytest

from sim.errors import ParameterError
from sim.units import spelled, to_si


def test_the_greek_mu_reads_as_the_micro_sign() -> None:
    """"30 μm" typed with U+03BC (a Greek keyboard, Word's autocorrect) was refused with a
    list holding a "µm" (U+00B5) that looks the same."""
    assert spelled(" \u03bcm ") == "\u00b5m"
    assert to_si(30.0, "\u03bcm", "m") == to_si(30.0, "\u00b5m", "m") == pytest.approx(30e-6)
    with pytest.raises(ParameterError, match="not a unit of this quantity"):
        to_si(30.0, "\u03bcs", "m")


def test_a_zero_rate_of_length_reads_in_the_unit_of_its_neighbours() -> None:
    """"slope 0 m/day" beside a table in µm/day (a plant operator's pass)."""
    from sim.units import quantity_text

    assert quantity_text(0.0, "m/day") == "0 µm/day"
    assert quantity_text(1.6e-6, "m/day", 3) == "1.6 µm/day"
    assert quantity_text(0.5, "m") == "0.5 m"
