"""The cylinder's scalar laws against hand calculations (paper 002 eqs. 33-36, 50)."""

from __future__ import annotations

import math

import pytest

from sim.components.cylinder import annulus_area, end_stop_force, piston_leakage_flow


def test_annulus_area_is_the_one_the_papers_loads_imply() -> None:
    # seeds README: 10/20/30 bar back-pressure ↔ 2.1/4.2/6.3 kN, an annulus of 2.12e-3 m²;
    # bore 60 mm, rod 30 mm: π·(0.060² − 0.030²)/4 = π·2.7e-3/4 = 2.1206e-3 m²
    area = annulus_area(0.060, 0.030)
    assert area == pytest.approx(2.1206e-3, rel=1e-4, abs=0)
    for bar, kN in ((10, 2.1), (20, 4.2), (30, 6.3)):
        assert bar * 1e5 * area / 1e3 == pytest.approx(kN, rel=0.01, abs=0)
    # no rod: the full piston face π·D²/4 (2.8274e-3 m² for 60 mm)
    assert annulus_area(0.060, 0.0) == pytest.approx(2.8274e-3, rel=1e-4, abs=0)


def test_piston_leakage_terms_match_hand_calculations() -> None:
    # Poiseuille, v = 0: π·D·c³·ΔP/(12·μ·L) with D = 60 mm, c = 83 µm, ΔP = 10 bar,
    # μ = 0.04 Pa·s, L = 12.31 mm: 0.188496 · 5.71787e-13 · 1e6 / 5.9088e-3 = 1.8240e-5 m³/s
    # (the seeds README's 1.8e-5 m³/s at 2.1 kN, the calibration of Lc)
    q_p = piston_leakage_flow(10e5, 0.0, 83e-6, 0.060, 0.01231, 0.04)
    assert q_p == pytest.approx(1.8240e-5, rel=1e-4, abs=0)
    # Couette, ΔP = 0, ẋ = 0.1 m/s towards chamber 2: relative to the piston the bore wall
    # moves at −ẋ and drags π·D·c·ẋ/2 = 0.188496 · 83e-6 · 0.05 = 7.8226e-7 m³/s back to
    # chamber 1 (negative: 2 → 1)
    q_c = piston_leakage_flow(0.0, 0.1, 83e-6, 0.060, 0.01231, 0.04)
    assert q_c == pytest.approx(-7.8226e-7, rel=1e-4, abs=0)
    # the law is the sum of the two (the flows of a linear Stokes problem superpose)
    assert piston_leakage_flow(10e5, 0.1, 83e-6, 0.060, 0.01231, 0.04) == pytest.approx(
        q_p + q_c, rel=1e-12, abs=0)


def test_piston_leakage_scales_as_the_annular_gap_laws_do() -> None:
    base = piston_leakage_flow(10e5, 0.0, 83e-6, 0.060, 0.01231, 0.04)
    # Poiseuille: c³, 1/μ, 1/L, ∝ ΔP and odd in it
    assert piston_leakage_flow(10e5, 0.0, 2 * 83e-6, 0.060, 0.01231, 0.04) == \
        pytest.approx(8.0 * base, rel=1e-12, abs=0)
    assert piston_leakage_flow(10e5, 0.0, 83e-6, 0.060, 0.01231, 0.08) == \
        pytest.approx(0.5 * base, rel=1e-12, abs=0)
    assert piston_leakage_flow(-10e5, 0.0, 83e-6, 0.060, 0.01231, 0.04) == \
        pytest.approx(-base, rel=1e-12, abs=0)
    # Couette: ∝ c, independent of μ and L
    drag = piston_leakage_flow(0.0, 0.1, 83e-6, 0.060, 0.01231, 0.04)
    assert piston_leakage_flow(0.0, 0.1, 2 * 83e-6, 0.060, 0.5, 1.0) == \
        pytest.approx(2.0 * drag, rel=1e-12, abs=0)
    assert math.copysign(1.0, drag) == -1.0


def test_end_stops_push_back_and_never_pull() -> None:
    # inside the stroke no force; 1 mm past the chamber-1 stop, at rest, a k = 1e8 N/m stop
    # pushes 1e5 N towards chamber 2, and 1 mm past the far stop as much back
    k, c, stroke = 1e8, 2e5, 0.5
    assert end_stop_force(0.25, 0.3, stroke, k, c) == 0.0
    assert end_stop_force(-1e-3, 0.0, stroke, k, c) == pytest.approx(1e5, rel=1e-12, abs=0)
    assert end_stop_force(stroke + 1e-3, 0.0, stroke, k, c) == pytest.approx(-1e5, rel=1e-12,
                                                                            abs=0)
    # leaving the stop faster than the spring unloads (c·v = 2e5·1 > k·x = 1e5): the damper
    # would pull the piston back, but a stop is a contact and cannot pull: 0
    assert end_stop_force(-1e-3, 1.0, stroke, k, c) == 0.0
    assert end_stop_force(stroke + 1e-3, -1.0, stroke, k, c) == 0.0
