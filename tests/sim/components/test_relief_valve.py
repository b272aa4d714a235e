"""The relief valve's law against hand calculations (paper 002 eq. 6)."""

from __future__ import annotations

import pytest

from sim.components.relief_valve import relief_flow


def test_shut_below_the_setting_and_linear_above_it() -> None:
    # paper 002 §2.6: Pset = 70 bar, Rrv = 2.5e9 Pa·s/m³; at 80 bar the valve passes
    # (8e6 − 7e6)/2.5e9 = 4e-4 m³/s (24 L/min), nothing at 60 bar, and nothing at the
    # setting itself (the law is continuous there)
    assert relief_flow(8e6, 7e6, 2.5e9, 0.0) == pytest.approx(4e-4, rel=1e-12, abs=0)
    assert relief_flow(6e6, 7e6, 2.5e9, 0.0) == 0.0
    assert relief_flow(7e6, 7e6, 2.5e9, 0.0) == 0.0
    # shut all the way up to the setting: no flow (and no flow into the rig) at 65 and
    # 69.9 bar (a mutation review: a valve cracking at 90 % of Pset passed the rig tests)
    for p in (6.5e6, 6.99e6):
        assert relief_flow(p, 7e6, 2.5e9, 0.0) == 0.0
    # ten bar more open it by a further 1e6/Rrv = 4e-4 m³/s
    assert relief_flow(9e6, 7e6, 2.5e9, 0.0) - relief_flow(8e6, 7e6, 2.5e9, 0.0) == \
        pytest.approx(4e-4, rel=1e-9, abs=0)


def test_a_leaking_seat_passes_gseat_times_the_pressure_at_every_pressure() -> None:
    # Gseat = 1e-12 m³/(s·Pa): 5e-6 m³/s at 50 bar, below the setting; above it the seat
    # leak adds to the opening flow: 8e-6 + 4e-4 m³/s at 80 bar
    assert relief_flow(5e6, 7e6, 2.5e9, 1e-12) == pytest.approx(5e-6, rel=1e-12, abs=0)
    assert relief_flow(8e6, 7e6, 2.5e9, 1e-12) == pytest.approx(8e-6 + 4e-4, rel=1e-12, abs=0)
