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
