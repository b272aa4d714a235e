"""The hose's lumped R, C, I against hand calculations (Hagen-Poiseuille; paper 000 §4)."""

from __future__ import annotations

import pytest

from sim.components.hose import hose_coefficients


def test_half_inch_hose_coefficients_by_hand() -> None:
    # d = 12.7 mm (r = 6.35 mm), L = 0.5 m, μ = 0.04 Pa·s, ρ = 870 kg/m³, β = 1.5e9 Pa:
    # R = 8·μ·L/(π·r⁴) = 0.16/(π·1.6259e-9) = 3.1324e7 Pa·s/m³ (Hagen-Poiseuille);
    # A = π·r² = 1.26677e-4 m²; C = A·L/β = 4.2226e-14 m³/Pa; I = ρ·L/A = 3.4339e6 kg/m⁴
    resistance, compliance, inertance = hose_coefficients(0.0127, 0.5, 0.04, 870.0, 1.5e9)
    assert resistance == pytest.approx(3.1324e7, rel=1e-4, abs=0)
    assert compliance == pytest.approx(4.2226e-14, rel=1e-4, abs=0)
    assert inertance == pytest.approx(3.4339e6, rel=1e-4, abs=0)


def test_hose_coefficients_scale_with_the_bore_as_the_laws_say() -> None:
    # doubling the bore: R falls 16-fold (d⁴), C rises 4-fold (area), I falls 4-fold;
    # the oil column's wave speed √(1/(C'·I')) per unit length is √(β/ρ) whatever the bore
    r1, c1, i1 = hose_coefficients(0.0127, 0.5, 0.04, 870.0, 1.5e9)
    r2, c2, i2 = hose_coefficients(0.0254, 0.5, 0.04, 870.0, 1.5e9)
    ratios = (r1 / r2, c2 / c1, i1 / i2)
    assert ratios == pytest.approx((16.0, 4.0, 4.0), rel=1e-12, abs=0)
    for c, i in ((c1, i1), (c2, i2)):
        wave_speed = 0.5 / (c * i) ** 0.5
        assert wave_speed == pytest.approx((1.5e9 / 870.0) ** 0.5, rel=1e-12, abs=0)
