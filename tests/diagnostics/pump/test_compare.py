"""Paired block bootstrap of two held-out S: hand calculations and its behaviour."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.pump.compare import QUADRATIC_TERMS, fold_s, quadratic_in_family, s_difference
from diagnostics.pump.piston import TORQUE_LOSS_TERMS, PistonMap, held_out_speed
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


def _quadratic_pump(b_dp: float) -> tuple[PistonMap, float]:
    """A pump whose losses are exactly quadratic in (Δp, ω), torque Coulomb term ``b_dp``."""
    w = np.repeat(np.array([500.0, 1500.0, 2500.0, 3500.0, 4500.0]) * math.pi / 30, 8)
    dp = np.tile(np.linspace(5e6, 35e6, 8), 5)
    D = 30e-6 / (2 * math.pi)
    q_loss = 1e-6 + 4e-13 * dp + 2e-14 * dp * w + 2e-20 * dp**2 + 2e-10 * w**2 - 1e-7 * w
    t_loss = 2.0 + b_dp * dp + 3e-2 * w + 1.5e-5 * w**2 + 3e-15 * dp**2 - 5e-10 * dp * w
    return PistonMap(dp, w, D * w - q_loss, D * dp + t_loss, np.full(dp.size, D)), D


def test_a_physical_quadratic_is_a_member_of_the_family() -> None:
    data, D = _quadratic_pump(1.6e-7)
    m = quadratic_in_family(data, D)
    assert m.flow_member and m.torque_member
    assert set(m.flow_coef) == set(m.torque_coef) == QUADRATIC_TERMS
    # exact data: the quadratic's loss coefficients are the pump's
    assert m.flow_coef["dp*omega"] == pytest.approx(2e-14, rel=1e-6, abs=0)
    assert m.flow_coef["omega"] == pytest.approx(-1e-7, rel=1e-6, abs=0)
    assert m.torque_coef["dp"] == pytest.approx(1.6e-7, rel=1e-6, abs=0)
    assert m.torque_coef["dp*omega"] == pytest.approx(-5e-10, rel=1e-6, abs=0)
    # a negative Coulomb friction is outside the family: not a member
    bad, D = _quadratic_pump(-1.6e-7)
    assert not quadratic_in_family(bad, D).torque_member
    with pytest.raises(InputError):
        quadratic_in_family(data.subset(np.arange(5)), D)


def test_fold_s_by_hand_and_the_fold_terms_are_kept() -> None:
    speed = np.repeat([100.0, 200.0], 3)
    y = np.full(6, 10.0)
    a = y + np.array([0.1, -0.1, 0.1, 0.3, 0.3, -0.3])
    sa, sb = fold_s(y, a, y, speed, 10.0)
    assert sa == pytest.approx([1.0, 3.0]) and sb == pytest.approx([0.0, 0.0])
    with pytest.raises(InputError):
        fold_s(y, a, y, speed, 0.0)
    # held_out_speed keeps the terms chosen with each speed left out, slowest first
    data, D = _quadratic_pump(1.6e-7)
    h = held_out_speed(data, D)
    assert len(h.fold_flow_terms) == len(h.fold_torque_terms) == h.speeds == 5
    assert all(set(t) <= {x.name for x in TORQUE_LOSS_TERMS} for t in h.fold_torque_terms)
