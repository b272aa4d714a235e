"""Shared fixtures: the stand-in pump and seeded virtual-bench runs (SIMULATED data)."""

from __future__ import annotations

import pytest

from diagnostics.pump import BenchData, default_levels, iso4409_grid, run_virtual_bench
from sim.components.gear_pump import GearPump
from sim.components.gear_pump_map import stand_in_pump


@pytest.fixture(scope="session")
def pump() -> GearPump:
    return stand_in_pump()


@pytest.fixture(scope="session")
def grid_bench(pump: GearPump) -> BenchData:
    """ISO 4409 grid 8 p x 7 n at 22 and 60 °C, 2 replicates, default instrument noise."""
    dp, w = iso4409_grid(*default_levels())
    return run_virtual_bench(pump, dp, w, (22.0, 60.0), replicates=2, seed=7)
