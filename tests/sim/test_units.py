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
