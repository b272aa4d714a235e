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
    # ASTM D341 (Walther) through (40 °C, 46 cSt) and (100 °C, 6.8 cSt), worked by hand:
    # log10 log10(ν + 0.7) = A − B·log10 T with A = 9.4180, B = 3.6844 (T in K, ν in cSt)
    # gives 20.623 cSt at 60 °C, 118.47 at 22 °C (paper 000's bench), 577.3 at 0 °C; the
    # ±10 % band above passed a law without its +0.7 cSt (20.06 cSt: a review)
    assert f.kinematic_viscosity(60.0) == pytest.approx(20.623e-6, rel=1e-4)
    assert f.kinematic_viscosity(22.0) == pytest.approx(118.47e-6, rel=1e-4)
    assert f.kinematic_viscosity(0.0) == pytest.approx(577.3e-6, rel=1e-4)


def test_density_and_dynamic_viscosity():
    f = Fluid()
    assert f.density(15.0) == pytest.approx(879.0)
    assert f.density(40.0) == pytest.approx(879.0 * (1 - 6.5e-4 * 25))
    assert f.dynamic_viscosity(40.0) == pytest.approx(f.density(40.0) * 46e-6)


def test_bad_fluid_and_temperature():
    with pytest.raises(ParameterError):
        Fluid(nu1=5e-6, nu2=50e-6)  # viscosity rising with temperature
    # at or below 0.3 cSt the Walther law has no value (a viscosity given in the wrong
    # unit crashed it: a verification pass)
    with pytest.raises(ParameterError, match=r"above 0\.3 cSt") as refused:
        Fluid(nu1=46e-6, nu2=0.25e-6)
    assert refused.value.field == "fluid.nu2"
    with pytest.raises(ParameterError):
        Fluid().kinematic_viscosity(400.0)


def test_equal_viscosities_at_two_temperatures_are_refused():
    # an oil whose viscosity does not fall between 40 °C and 100 °C is no mineral oil, and
    # Walther's B would be 0 (a constant viscosity at every temperature): refused, as a
    # rising one is (a mutation review: ">= 0" read as "> 0" let it through)
    with pytest.raises(ParameterError) as refused:
        Fluid(nu1=46e-6, nu2=46e-6)
    assert refused.value.field == "fluid.nu2"


def test_the_temperature_range_is_closed_at_both_ends():
    # -60 °C and 250 °C are the stated limits of the law (module docstring's range) and
    # are inside it; at 250 °C a VG 46 is thinner than at 100 °C but still above the
    # Walther floor of 0.3 cSt, at -60 °C thicker than at 0 °C
    f = Fluid()
    hot, cold = f.kinematic_viscosity(250.0), f.kinematic_viscosity(-60.0)
    assert 0.3e-6 < hot < f.kinematic_viscosity(100.0)
    assert cold > f.kinematic_viscosity(0.0)
    for outside in (250.01, -60.01):
        with pytest.raises(ParameterError):
            f.kinematic_viscosity(outside)
