"""Inversions of the piston and spool leakage laws on plain numbers (paper 002 eqs. 23, 36)."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.leakage_laws import leakage_root, spool_clearance
from sim.errors import InputError


def test_negative_leak_without_drag_has_no_clearance() -> None:
    # b = 0 (no piston motion): a·c³ = q has no root c ≥ 0 for q < 0 — no clearance
    # makes oil flow against the pressure difference; 0 is returned (module docstring),
    # not the clearance of the leak's magnitude
    a = 1e7
    assert float(leakage_root(a, 0.0, -1e-6)[()]) == 0.0
    assert float(leakage_root(a, 0.0, 1e-6)[()]) == pytest.approx((1e-6 / a) ** (1 / 3),
                                                                  rel=1e-12, abs=0)
    # b < 0 (motion with the Poiseuille flow): likewise no root for q < 0
    assert float(leakage_root(a, -1e-3, -1e-6)[()]) == 0.0


def test_spool_clearance_needs_a_pressure_difference() -> None:
    # at ΔP = 0 the spool law Q = π·Dv·cv³·ΔP/(12·μ·Ls) gives 0 whatever the clearance:
    # refused, as a negative ΔP is (a mutation review: "ΔP ≥ 0" returned inf)
    for dp in (0.0, -1e5):
        with pytest.raises(InputError) as refused:
            spool_clearance(1e-6, dp, 0.0125, 4.739e-4, 0.04)
        assert refused.value.field == "dp"


def test_roots_satisfy_the_cubic_to_round_off() -> None:
    # the closed forms (sinh, cosh, cos of a third of an angle) lose a few ulps; the
    # Newton step the module docstring promises brings the backward residual
    # |a·c³ − b·c − q| down to the round-off of the larger term (≤ 1.5e-15 relative here;
    # without the step it reached 3e-15 on this sample, a mutation review)
    rng = np.random.default_rng(11)
    n = 20_000
    a = 10 ** rng.uniform(3, 9, n)
    b = rng.choice([-1.0, 0.0, 1.0], n) * 10 ** rng.uniform(-4, 0, n)
    c_star = np.sqrt(np.abs(b) / (3 * a)) * (b > 0)
    c = c_star + 10 ** rng.uniform(-6, -3, n)
    q = a * c**3 - b * c
    root = leakage_root(a, b, q)
    scale = np.maximum(a * root**3, np.abs(b) * root)
    assert np.max(np.abs(a * root**3 - b * root - q) / scale) <= 1.5e-15
