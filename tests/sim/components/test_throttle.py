"""The throttle's orifice law against hand calculations (Merritt ch. 3; paper 002 §2.7)."""

from __future__ import annotations

import math

import pytest

from sim.components.throttle import throttle_flow


def test_an_open_throttle_is_a_sharp_edged_orifice() -> None:
    # far above p_tr: Q = Kt·θⁿ·√ΔP; Kt = 1.72e-8 m³/(s·Pa^0.5) (the reference rig's
    # throttle I), θ = 2 turns, n = 2, ΔP = 10 bar: 1.72e-8 · 4 · 1000 = 6.88e-5 m³/s
    q = throttle_flow(10e5, 1.72e-8, 2.0, 2.0, 2e3)
    assert q == pytest.approx(6.88e-5, rel=1e-5, abs=0)
    # √ΔP: four times the drop, twice the flow; the area grows as θ²: half a turn less
    # than 2 turns passes (1.5/2)² of it
    assert throttle_flow(40e5, 1.72e-8, 2.0, 2.0, 2e3) == pytest.approx(2 * q, rel=1e-5, abs=0)
    assert throttle_flow(10e5, 1.72e-8, 2.0, 1.5, 2e3) == pytest.approx(0.5625 * q, rel=1e-12, abs=0)
    # odd in ΔP: the flow reverses with the drop
    assert throttle_flow(-10e5, 1.72e-8, 2.0, 2.0, 2e3) == pytest.approx(-q, rel=1e-12, abs=0)


def test_below_the_transition_the_throttle_is_laminar_and_shut_it_passes_nothing() -> None:
    # ΔP ≪ p_tr: Q → Kt·θⁿ·ΔP/√p_tr, linear in ΔP (finite dQ/dΔP at 0):
    # 1.72e-8 · 4 · 10 / √2000 = 1.5386e-8 m³/s at 10 Pa
    q = throttle_flow(10.0, 1.72e-8, 2.0, 2.0, 2e3)
    assert q == pytest.approx(1.72e-8 * 4 * 10 / math.sqrt(2e3), rel=1e-4, abs=0)
    assert throttle_flow(20.0, 1.72e-8, 2.0, 2.0, 2e3) == pytest.approx(2 * q, rel=1e-4, abs=0)
    assert throttle_flow(10e5, 1.72e-8, 2.0, 0.0, 2e3) == 0.0
