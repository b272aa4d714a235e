"""The 4/2 valve's scalar laws against hand calculations (paper 002 eqs. 19-23)."""

from __future__ import annotations

import pytest

from sim.components.directional_valve import path_flow, spool_leakage_flow


def test_spool_leakage_matches_a_hand_calculation() -> None:
    # paper 002 eq. 23, laminar annulus: π·Dv·cv³·ΔP/(12·μ·Ls) with Dv = 12.5 mm,
    # cv = 34 µm, ΔP = 70 bar, μ = 0.04 Pa·s, Ls = 0.4739 mm:
    # π·0.0125 = 0.0392699; ·(34e-6)³ = 1.54346e-15; ·7e6 = 1.08042e-8;
    # / (12·0.04·4.739e-4 = 2.27472e-4) = 4.7497e-5 m³/s
    q = spool_leakage_flow(7e6, 34e-6, 0.0125, 4.739e-4, 0.04)
    assert q == pytest.approx(4.7497e-5, rel=1e-4, abs=0)
    # cube law in the clearance, inverse in viscosity and sealing length
    assert spool_leakage_flow(7e6, 68e-6, 0.0125, 4.739e-4, 0.04) == pytest.approx(8 * q)
    assert spool_leakage_flow(7e6, 34e-6, 0.0125, 4.739e-4, 0.08) == pytest.approx(q / 2)
    assert spool_leakage_flow(7e6, 34e-6, 0.0125, 2 * 4.739e-4, 0.04) == pytest.approx(q / 2)


def test_open_path_is_an_orifice_and_a_closed_one_passes_nothing() -> None:
    # far above the transition pressure Q = K·N·√ΔP: K = 1e-7 m³/(s·Pa^0.5), N = 0.5,
    # ΔP = 1e6 Pa: 1e-7 · 0.5 · 1000 = 5e-5 m³/s; four times ΔP doubles it
    K, p_tr = 1e-7, 1e3
    q = path_flow(1e6, K, 0.5, 1.0, p_tr)
    assert q == pytest.approx(5e-5, rel=1e-6, abs=0)
    assert path_flow(4e6, K, 0.5, 1.0, p_tr) == pytest.approx(2 * q, rel=1e-6, abs=0)
    # odd in ΔP, and the paths the spool shuts (direction·N ≤ 0) carry nothing
    assert path_flow(-1e6, K, 0.5, 1.0, p_tr) == pytest.approx(-q, rel=1e-12, abs=0)
    assert path_flow(1e6, K, 0.5, -1.0, p_tr) == 0.0
    assert path_flow(1e6, K, -0.5, -1.0, p_tr) == pytest.approx(q, rel=1e-12, abs=0)
