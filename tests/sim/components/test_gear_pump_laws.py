"""The gear pump's bond-graph laws as scalar functions (paper 000 eqs. 14-15)."""

from __future__ import annotations

import math

import pytest

from sim.components.gear_pump_laws import load_torque

D = 14.7e-6 / (2.0 * math.pi)  # paper 000 §3.1: 14.7 cm³/rev [m³/rad]
#: a constant Cf = 0.02 as the 16 coefficients of the bicubic surface (c[0] the constant)
CF = (0.02,) + (0.0,) * 15


def test_coulomb_torque_follows_the_load_not_its_sign() -> None:
    # eq. 15: Tf = Cf·|Δp|·D·sgn(ω): the bearing and flank load grows with |Δp| and the
    # friction opposes the rotation, so an outlet below the inlet (Δp < 0, an overrunning
    # load) gives the same torque as the same |Δp| pumping.  Cf = 0.02 at 100 bar and
    # 150 rad/s: 0.02 · 1e7 · 2.3396e-6 = 0.46791 N·m (a mutation review: Δp for |Δp|
    # turned the friction into a drive)
    pumping = load_torque(150.0, 1e7, D, 1e-3, 1e7, 150.0, *CF)
    assert pumping == pytest.approx(0.02 * 1e7 * D, rel=1e-12, abs=0)
    assert pumping == pytest.approx(0.46791, rel=1e-4, abs=0)
    assert load_torque(150.0, -1e7, D, 1e-3, 1e7, 150.0, *CF) == pytest.approx(
        pumping, rel=1e-12, abs=0)
    # turning backwards reverses it
    assert load_torque(-150.0, 1e7, D, 1e-3, 1e7, 150.0, *CF) == pytest.approx(
        -pumping, rel=1e-12, abs=0)
