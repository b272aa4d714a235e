"""Fluid properties: Walther (ASTM D341) viscosity through the two reference points."""

from __future__ import annotations

import itertools

import pytest

from sim.errors import ParameterError
from sim.fluid import Fluid


def test_walther_passes_through_reference_points_and_falls_with_temperature():
    f = Fluid()
    assert f.kinematic_viscosity(40.0) == pytest.approx(46e-6, rel=1e-12)
    assert f.kinematic_viscosity(100.0) == pytest.approx(6.8e-6, rel=1e-12)
    temps = [0.0, 22.0, 40.0, 60.0, 80.0, 100.0]
    nus = [f.kinematic_viscosity(t) for t in temps]
    assert all(a > b for a, b in itertools.pairwise(nus))
    # ISO VG 46 data sheets give ≈ 20-22 cSt at 60 °C
    assert 19e-6 < f.kinematic_viscosity(60.0) < 23e-6


def test_density_and_dynamic_viscosity():
    f = Fluid()
    assert f.density(15.0) == pytest.approx(879.0)
    assert f.density(40.0) == pytest.approx(879.0 * (1 - 6.5e-4 * 25))
    assert f.dynamic_viscosity(40.0) == pytest.approx(f.density(40.0) * 46e-6)


def test_bad_fluid_and_temperature():
    with pytest.raises(ParameterError):
        Fluid(nu1=5e-6, nu2=50e-6)  # viscosity rising with temperature
    with pytest.raises(ParameterError):
        Fluid().kinematic_viscosity(400.0)
