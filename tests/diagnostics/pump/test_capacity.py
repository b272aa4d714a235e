"""Derived capacity: Toet within 0.5 %, the ISO 8426 intercept's bias, Vimax's ηv = 1."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.pump import (
    BenchData,
    InstrumentNoise,
    default_levels,
    derived_capacity_intercept,
    derived_capacity_toet,
    derived_capacity_vimax,
    iso4409_grid,
    latin_hypercube_plan,
    run_virtual_bench,
    volumetric_efficiency,
)
from sim.components.gear_pump import CoefficientSurface, GearPump
from sim.components.gear_pump_map import MAP_OMEGA_RANGE, MAP_P_RANGE
from sim.errors import InputError


def _clean(pump: GearPump) -> BenchData:
    dp, w = iso4409_grid(*default_levels())
    return run_virtual_bench(pump, dp, w, (22.0, 60.0), noise=InstrumentNoise.none())


def test_toet_is_exact_when_slip_does_not_depend_on_speed(pump: GearPump) -> None:
    flat = GearPump(Cs=CoefficientSurface.constant(3e-9), Cst=CoefficientSurface.constant(6e-5),
                    Cv=pump.Cv, Cf=pump.Cf)
    est = derived_capacity_toet(_clean(flat), level="all")
    assert abs(est.D / flat.D - 1) < 1e-9


def test_toet_within_half_a_percent_on_noisy_bench(pump: GearPump, grid_bench: BenchData
                                                   ) -> None:
    est = derived_capacity_toet(grid_bench)
    assert abs(est.D / pump.D - 1) < 0.005
    assert est.std / pump.D < 0.005
    assert sorted(est.per_temperature) == [pytest.approx(22.0, abs=0.3),
                                           pytest.approx(60.0, abs=0.3)]


def test_toet_is_biased_by_speed_dependent_slip_in_hot_oil(pump: GearPump) -> None:
    est = derived_capacity_toet(_clean(pump), level="all")
    cold, hot = (est.per_temperature[k] / pump.D - 1 for k in sorted(est.per_temperature))
    assert abs(cold) < 0.002 < hot


def test_intercept_underestimates_and_gives_efficiency_above_one(pump: GearPump) -> None:
    est = derived_capacity_intercept(_clean(pump))
    assert est.D < pump.D * (1 - 0.002)
    P, W = np.meshgrid(np.linspace(*MAP_P_RANGE, 20), np.linspace(*MAP_OMEGA_RANGE, 20))
    ev_true = pump.flow(P, W, 22.0) / (pump.D * W)
    ev_intercept = pump.flow(P, W, 22.0) / (est.D * W)
    assert ev_true.max() < 1.0 < ev_intercept.max()          # the pitfall of paper 000 §3.1


def test_vimax_gives_one_point_at_exactly_100_percent(grid_bench: BenchData) -> None:
    est = derived_capacity_vimax(grid_bench)
    ev = volumetric_efficiency(grid_bench, est.D)
    assert ev.max() == pytest.approx(1.0, abs=1e-15) and np.sum(ev > 1 - 1e-15) == 1


def test_toet_needs_a_grid(pump: GearPump) -> None:
    dp, w = latin_hypercube_plan(30, MAP_P_RANGE, MAP_OMEGA_RANGE, seed=1)
    b = run_virtual_bench(pump, dp, w, (22.0,), seed=1)
    with pytest.raises(InputError) as e:
        derived_capacity_toet(b)
    assert e.value.field == "n"


def test_intercept_and_its_standard_error_by_hand() -> None:
    # three points at one temperature, q/ω = 1, 2, 2 [1e-7 m³/rad] at Δp = 1, 2, 3 MPa:
    # least squares gives slope 0.5 per MPa and intercept 2/3; residuals −1/6, 1/3, −1/6,
    # s² = Σr²/(n − 2) = (1/6)/1, Var(a) = s²·(1/n + x̄²/Sxx) = (1/6)·(1/3 + 4/2) = 7/18,
    # se(a) = 0.62361 [1e-7 m³/rad] (a mutation review: s² over n read 0.36)
    omega = np.full(3, 100.0)
    data = BenchData(p_in=np.zeros(3), p_out=np.array([1e6, 2e6, 3e6]), omega=omega,
                     theta=np.full(3, 40.0), q=np.array([1.0, 2.0, 2.0]) * 1e-7 * omega)
    est = derived_capacity_intercept(data)
    capacity = est.D
    assert capacity == pytest.approx(2.0 / 3.0 * 1e-7, rel=1e-9, abs=0)
    assert est.std == pytest.approx(np.sqrt(7.0 / 18.0) * 1e-7, rel=1e-9, abs=0)


def test_per_rev_is_the_capacity_per_radian_times_two_pi(pump: GearPump) -> None:
    # paper 000 §3.1: 14.7 cm³/rev, i.e. 14.7e-6/(2π) = 2.3396e-6 m³/rad
    est = derived_capacity_toet(_clean(pump))
    assert est.per_rev == pytest.approx(est.D * 6.283185, rel=1e-6, abs=0)
    assert est.per_rev == pytest.approx(14.7e-6, rel=0.005, abs=0)


def test_all_levels_are_combined_by_inverse_variance() -> None:
    # two temperature levels whose intercepts are 1 and 2 with standard errors 1 and 2:
    # weights 1 and 1/4, mean (1 + 0.5)/1.25 = 1.2, standard error 1/√1.25 = 0.89443
    from diagnostics.pump.capacity import _combine

    assert _combine([1.0, 2.0], [1.0, 2.0], [22.0, 60.0], "all") == pytest.approx(
        (1.2, 0.89443), rel=1e-5, abs=0)
    assert _combine([1.0, 2.0], [1.0, 2.0], [60.0, 22.0], "coldest") == (2.0, 2.0)


def test_toet_slopes_weigh_each_reading_by_its_relative_error() -> None:
    # the flowmeter's error is a fraction of its reading, so each speed line ∂q/∂ω is fitted
    # with weights 1/q² (Σ of squared relative residuals).  At every pressure level, q =
    # 1, 2, 4 [1e-5 m³/s] at ω = 100, 200, 300 rad/s (x = 1, 2, 3): weights 1, 1/4, 1/16,
    # weighted means x̄ = 9/7, ȳ = 4/3, Σw·dx·dy = 1/2, Σw·dx² = 19.25/49, slope 14/11
    # [1e-7 m³/rad]; equal slopes at every pressure make the Δp = 0 intercept 14/11·1e-7.
    # Unweighted the slope reads 3/2 (a mutation review)
    p = np.repeat([1e6, 2e6, 3e6], 3)
    omega = np.tile([100.0, 200.0, 300.0], 3)
    q = np.tile([1.0, 2.0, 4.0], 3) * 1e-5
    data = BenchData(p_in=np.zeros(9), p_out=p, omega=omega, theta=np.full(9, 40.0), q=q)
    capacity = derived_capacity_toet(data).D
    assert capacity == pytest.approx(14.0 / 11.0 * 1e-7, rel=1e-9, abs=0)
