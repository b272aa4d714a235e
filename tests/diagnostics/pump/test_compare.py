"""Paired block bootstrap of two held-out S: hand calculations and its behaviour."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.pump.compare import s_difference
from sim.errors import InputError


def test_difference_of_s_by_hand() -> None:
    speed = np.repeat([100.0, 200.0, 300.0], 4)
    y = np.full(12, 10.0)
    a = y + 0.1  # rms error 0.1 → S 1 % of 10
    b = y + np.where(speed == 300.0, 0.4, 0.1)  # rms √((8·0.01 + 4·0.16)/12)
    d = s_difference(y, a, b, speed, 10.0, reps=500)
    assert d.difference == pytest.approx(100 / 10 * (0.1 - math.sqrt((8 * 0.01 + 4 * 0.16) / 12)))
    assert d.blocks == 3 and d.level == 0.95
    # every resample has a at 1 % and b at least 1 %: the interval never crosses 0
    assert d.high <= 1e-12 and d.low < d.difference < d.high + 1e-12


def test_identical_models_differ_by_nothing_and_noise_straddles_zero() -> None:
    rng = np.random.default_rng(5)
    speed = np.repeat(np.arange(1.0, 9.0) * 100.0, 12)
    y = rng.normal(0.0, 1.0, speed.size)
    same = s_difference(y, y * 0.0, y * 0.0, speed, 1.0)
    assert same.difference == 0.0 and same.low == 0.0 and same.high == 0.0
    # two equally good but different models: the interval holds zero
    a = rng.normal(0.0, 0.5, speed.size)
    b = rng.normal(0.0, 0.5, speed.size)
    d = s_difference(y, y + a, y + b, speed, 1.0)
    assert d.low < 0.0 < d.high


def test_bad_input_is_refused() -> None:
    y = np.ones(6)
    with pytest.raises(InputError):
        s_difference(y, y, y[:5], np.arange(6.0), 1.0)
    with pytest.raises(InputError):
        s_difference(y, y, y, np.full(6, 100.0), 1.0)
    with pytest.raises(InputError):
        s_difference(y, y, y, np.arange(6.0), 0.0)
