"""Physics of the gear pump loss model (paper 000 eqs. 6, 16) and of the stand-in map."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.components.gear_pump import (
    PARAMETERS,
    CoefficientSurface,
    GearPump,
    dynamic_viscosity,
    flow_losses,
    gear_pump_flow,
    gear_pump_torque,
    mechanical_efficiency,
    volumetric_efficiency,
)
from sim.components.gear_pump_map import (
    MAP_OMEGA_RANGE,
    MAP_P_RANGE,
    MAP_TEMPERATURES,
    stand_in_coefficients,
    stand_in_pump,
)
from sim.errors import ParameterError
from sim.fluid import Fluid

RPM = 2 * math.pi / 60
D = 14.7e-6 / (2 * math.pi)


def _grid(n: int = 25) -> tuple[np.ndarray, np.ndarray]:
    P, W = np.meshgrid(np.linspace(*MAP_P_RANGE, n), np.linspace(*MAP_OMEGA_RANGE, n))
    return P, W


def test_zero_pressure_gives_geometric_flow_whatever_the_coefficients() -> None:
    w = np.array([50.0, 150.0, 250.0])
    q = gear_pump_flow(0.0, w, 0.03, D=D, Cs=-5e-9, Cst=1e-3, rho=870.0, beta_ef=1.2e9)
    np.testing.assert_allclose(q, D * w, rtol=1e-15)


def test_each_flow_loss_follows_its_law() -> None:
    dp, w, mu = 1e7, 150.0, 0.03
    qs, qst, qc = flow_losses(dp, w, mu, D=D, Cs=3e-9, Cst=6e-5, rho=870.0, beta_ef=1.5e9)
    qs2, qst2, qc2 = flow_losses(4 * dp, 2 * w, 2 * mu, D=D, Cs=3e-9, Cst=6e-5, rho=870.0,
                                 beta_ef=1.5e9)
    assert qs2 == pytest.approx(2 * qs)          # ∝ Δp/μ (eq. 4)
    assert qst2 == pytest.approx(2 * qst)        # ∝ √Δp, viscosity-free (eq. 5)
    assert qc2 == pytest.approx(8 * qc)          # ∝ Δp·ω (eq. 6)
    assert qc == pytest.approx(dp * D * w / 1.5e9)


def test_turbulent_term_uses_eq9_exponent_and_is_a_flow() -> None:
    # √(2Δp·D^(4/3)/ρ): doubling D multiplies the turbulent loss by 2^(2/3), not 2² (eq. 5's D⁴)
    a = flow_losses(1e7, 100.0, 0.03, D=D, Cs=0.0, Cst=1e-4, rho=870.0, beta_ef=1e9)[1]
    b = flow_losses(1e7, 100.0, 0.03, D=2 * D, Cs=0.0, Cst=1e-4, rho=870.0, beta_ef=1e9)[1]
    assert float(b / a) == pytest.approx(2 ** (2 / 3), rel=1e-12)
    # Cst dimensionless: value in m³/s of the order of a few % of the geometric flow
    assert 1e-7 < float(a) < 1e-4


def test_negative_pressure_rise_refused() -> None:
    with pytest.raises(ParameterError) as e:
        gear_pump_flow(-1.0, 100.0, 0.03, D=D, Cs=1e-9, Cst=1e-5, rho=870.0, beta_ef=1e9)
    assert e.value.field == "dp"


def test_torque_is_ideal_plus_losses_and_gives_eq17_back() -> None:
    dp, w, cv, cf = 1.5e7, 157.0, 2.5e4, 0.05
    t1 = gear_pump_torque(dp, w, 0.09, D=D, Cv=cv, Cf=cf)
    t2 = gear_pump_torque(dp, w, 0.02, D=D, Cv=cv, Cf=cf)
    assert float(t1) > float(t2) > dp * D                # pump: losses add to Δp·D
    assert float((t1 - t2) / ((0.09 - 0.02) * w * D)) == pytest.approx(cv)   # eq. 17
    assert float(gear_pump_torque(0.0, w, 0.05, D=D, Cv=cv, Cf=cf)) == pytest.approx(
        cv * 0.05 * w * D)


def test_surface_evaluates_the_polynomial() -> None:
    c = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    s = CoefficientSurface(c, p_ref=1e7, omega_ref=100.0)
    x, y = 0.7, 1.3
    expected = sum(c[i, j] * x**i * y**j for i in range(3) for j in range(2))
    assert float(s(7e6, 130.0)) == pytest.approx(expected)
    assert s.degrees == (2, 1)
    assert float(CoefficientSurface.constant(4.2)(1e7, 55.0)) == 4.2
    with pytest.raises(ParameterError):
        CoefficientSurface(np.array([[np.nan]]))


def test_vectorised_viscosity_matches_the_fluid() -> None:
    fl = Fluid()
    th = np.array([22.0, 60.0, 22.0, 40.0])
    np.testing.assert_allclose(dynamic_viscosity(fl, th),
                               [fl.dynamic_viscosity(float(t)) for t in th], rtol=1e-15)


def test_parameters_have_units_and_sources() -> None:
    names = {p.name for p in PARAMETERS}
    assert names == {"D", "rho", "beta_ef"}
    assert all(p.source and p.unit for p in PARAMETERS)
    d = next(p for p in PARAMETERS if p.name == "D")
    assert d.default * 2 * math.pi == pytest.approx(14.7e-6)


def test_domain_of_the_map() -> None:
    pump = stand_in_pump()
    inside = pump.in_range([20e5, 250e5, 10e5, 100e5], [600 * RPM, 2400 * RPM, 100.0, 300.0])
    assert inside.tolist() == [True, True, False, False]


def test_pump_refuses_bad_parameters() -> None:
    c = stand_in_coefficients()
    with pytest.raises(ParameterError) as e:
        GearPump(Cs=c["Cs"], Cst=c["Cst"], Cv=c["Cv"], Cf=c["Cf"], D=0.0)
    assert e.value.field == "D"


def test_stand_in_map_volumetric_efficiency_between_90_and_100_percent() -> None:
    pump = stand_in_pump()
    P, W = _grid()
    for th in MAP_TEMPERATURES:
        ev = volumetric_efficiency(pump.flow(P, W, th), W, pump.D)
        assert ev.max() < 1.0
        assert ev.min() > 0.90            # paper 000 §3.1: above 90 % over the range
    # hot oil leaks more than cold oil everywhere except where Cs < 0 (Couette region)
    cs = pump.Cs(P, W)
    hot, cold = pump.flow(P, W, 60.0), pump.flow(P, W, 22.0)
    assert np.all((hot < cold) == (cs > 0))


def test_stand_in_map_mechanical_efficiency_below_one() -> None:
    pump = stand_in_pump()
    P, W = _grid()
    for th in MAP_TEMPERATURES:
        em = mechanical_efficiency(pump.torque(P, W, th), P, pump.D)
        assert em.min() > 0.7 and em.max() < 1.0


def test_stand_in_map_follows_figure_3_description() -> None:
    c = stand_in_coefficients()
    p = np.linspace(*MAP_P_RANGE, 47)
    # Cs falls with pressure at low and middle speeds, falls with speed everywhere
    for rpm in (600, 1000, 1500):
        assert np.all(np.diff(c["Cs"](p, rpm * RPM)) < 0)
    speeds = np.linspace(600, 2400, 37) * RPM
    for pp in (20e5, 100e5, 250e5):
        assert np.all(np.diff(c["Cs"](pp, speeds)) < 0)
    # ... and is negative at low pressure at 2200 and 2400 rpm only
    assert float(c["Cs"](20e5, 2200 * RPM)) < 0 and float(c["Cs"](20e5, 2400 * RPM)) < 0
    assert float(c["Cs"](20e5, 1800 * RPM)) > 0 and np.all(c["Cs"](p, 1500 * RPM) > 0)
    # Cst grows up to about 150 bar
    cst = c["Cst"](p, 1500 * RPM)
    assert 130e5 <= p[int(np.argmax(cst))] <= 170e5
    # Cf falls quickly from 0 to 100 bar: most of its fall happens there
    cf0, cf100, cf250 = (float(c["Cf"](x, 1500 * RPM)) for x in (0.0, 100e5, 250e5))
    assert cf0 > cf100 > cf250 > 0 and (cf0 - cf100) > 0.6 * (cf0 - cf250)
    # Cv rises as the films thin (with pressure)
    assert np.all(np.diff(c["Cv"](p, 1500 * RPM)) > 0)
