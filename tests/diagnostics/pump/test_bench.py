"""The virtual ISO 4409 bench: exact without noise, the stated bounds with it, seeded."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.pump import InstrumentNoise, iso4409_grid, run_virtual_bench
from diagnostics.quantity import DEFAULT_INSTRUMENTS
from sim.components.gear_pump import GearPump
from sim.errors import InputError


def test_without_noise_the_bench_returns_the_model(pump: GearPump) -> None:
    dp, w = iso4409_grid([20e5, 150e5], [80.0, 200.0])
    b = run_virtual_bench(pump, dp, w, (22.0, 60.0), noise=InstrumentNoise.none(),
                          replicates=2, p_in=3e4)
    assert len(b) == 4 * 2 * 2 and b.simulated
    np.testing.assert_allclose(b.dp, np.tile(dp, 4), rtol=1e-12)
    np.testing.assert_allclose(b.q, pump.flow(b.dp, b.omega, b.theta), rtol=1e-15)
    np.testing.assert_allclose(b.require_torque(), pump.torque(b.dp, b.omega, b.theta))
    assert sorted(set(b.theta)) == [22.0, 60.0] and sorted(set(b.replicate)) == [0, 1]


def test_noise_has_the_stated_size_and_is_seeded(pump: GearPump) -> None:
    dp = np.full(4000, 1e7)
    w = np.full(4000, 150.0)
    nz = InstrumentNoise()
    b = run_virtual_bench(pump, dp, w, (40.0,), noise=nz, seed=3)
    rel_q = b.q / pump.flow(1e7, 150.0, 40.0) - 1
    rel_p = b.p_out / 1e7 - 1
    # a bound ±a read as rectangular (GUM 4.3.7, as diagnostics.quantity does): u = a/√3,
    # and no reading leaves the bound
    assert nz.sigma("flow") == pytest.approx(0.01 / np.sqrt(3), rel=1e-12)
    assert nz.sigma("flow") == DEFAULT_INSTRUMENTS["pump_flow"].reading(1.0).u
    assert np.std(rel_q) == pytest.approx(0.01 / np.sqrt(3), rel=0.05)
    assert np.std(rel_p) == pytest.approx(0.0025 / np.sqrt(3), rel=0.05)
    assert np.std(b.theta - 40.0) == pytest.approx(1.0 / np.sqrt(3), rel=0.05)
    assert np.abs(rel_q).max() <= 0.01 and np.abs(rel_p).max() <= 0.0025
    assert np.abs(b.theta - 40.0).max() <= 1.0
    assert np.abs(rel_q).max() > 0.99 * 0.01          # uniform: the bound is reached
    assert abs(np.mean(rel_q)) < 4 * nz.sigma("flow") / np.sqrt(4000)
    again = run_virtual_bench(pump, dp, w, (40.0,), noise=nz, seed=3)
    np.testing.assert_array_equal(again.q, b.q)
    other = run_virtual_bench(pump, dp, w, (40.0,), noise=nz, seed=4)
    assert not np.array_equal(other.q, b.q)


def test_full_scale_flow_error_is_constant(pump: GearPump) -> None:
    nz = InstrumentNoise(flow_full_scale=1e-3)
    w = np.repeat([70.0, 250.0], 3000)
    b = run_virtual_bench(pump, np.full(6000, 5e6), w, (40.0,), noise=nz, seed=1)
    err = b.q - pump.flow(5e6, w, 40.0)
    lo, hi = np.std(err[:3000]), np.std(err[3000:])
    u = 1e-5 / np.sqrt(3)                      # ±1 % of 1e-3 m³/s, rectangular
    assert lo == pytest.approx(u, rel=0.06) and hi == pytest.approx(u, rel=0.06)
    assert np.abs(err).max() <= 1e-5
    np.testing.assert_allclose(nz.flow_sigma([1e-4, 1e-3]), [u, u], rtol=1e-12)


def test_bad_plans_are_refused(pump: GearPump) -> None:
    with pytest.raises(InputError) as e:
        run_virtual_bench(pump, [1e7, 2e7], [100.0], (22.0,))
    assert e.value.field == "omega"
    with pytest.raises(InputError) as e:
        run_virtual_bench(pump, [1e7], [100.0], (22.0,), replicates=0)
    assert e.value.field == "replicates"
    with pytest.raises(InputError) as e:
        InstrumentNoise(flow=-0.01)
    assert e.value.field == "flow"
