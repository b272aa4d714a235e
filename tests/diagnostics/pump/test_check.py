"""A loss model checked against its own points: the V32HL56 slice and the virtual bench."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.pump import BenchData, bench_from_frame
from diagnostics.pump.check import check_losses
from diagnostics.pump.levels import cluster_levels
from diagnostics.pump.piston import bench_frame, held_out_speed, read_efficiency_map
from sim.components.gear_pump import GearPump
from sim.errors import InputError
from tests.real_slices import v32hl56_slice


def _full_stroke() -> tuple[BenchData, float]:
    m = read_efficiency_map(v32hl56_slice())
    idx, lev = cluster_levels(m.D, field="D")
    k = int(np.argmax(lev))
    return bench_from_frame(bench_frame(m.subset(idx == k), 50.0)), float(lev[k])


def test_one_temperature_map_is_checked_point_by_point() -> None:
    bench, D = _full_stroke()
    c = check_losses(bench, D)
    assert len(c.levels) == 1 and not c.skipped and c.mask.all()
    assert c.levels[0].theta == pytest.approx(50.0)
    # the stored predictions are those of the held-out check itself
    m = read_efficiency_map(v32hl56_slice())
    idx, lev = cluster_levels(m.D, field="D")
    h = held_out_speed(m.subset(idx == int(np.argmax(lev))), D)
    assert np.allclose(c.q_held_out, h.flow_pred, rtol=1e-12)
    assert c.flow_S == pytest.approx(h.flow_S, rel=1e-12)
    # S is the rms of the stored residuals, over the largest flow
    res = bench.q - c.q_held_out
    assert c.flow_S == pytest.approx(100 * math.sqrt(float(np.mean(res**2)))
                                     / float(bench.q.max()))
    assert 0 < c.flow_S < 0.3 and 0 < c.torque_S < 0.5


def test_two_temperatures_are_checked_level_by_level(grid_bench: BenchData,
                                                     pump: GearPump) -> None:
    # the virtual gear pump at 22 and 60 °C: each level is its own fit
    c = check_losses(grid_bench, pump.D)
    assert [round(lv.theta) for lv in c.levels] == [22, 60]
    assert c.mask.all() and c.q_held_out.shape == grid_bench.q.shape
    # the leakage of a gear pump is larger in thin (hot) oil: more laminar-loss coefficient
    losses = [lv.held_out.flow.loss(np.array([1e7]), np.array([150.0]))[0] for lv in c.levels]
    assert losses[1] > losses[0] > 0


def test_what_cannot_be_checked_is_refused_with_the_reason() -> None:
    bench, D = _full_stroke()
    two_speeds = bench.subset(bench.omega < np.sort(np.unique(np.round(bench.omega)))[2] - 1)
    with pytest.raises(InputError) as err:
        check_losses(two_speeds, D)
    assert err.value.field == "n" and "leaving one out needs ≥ 3" in err.value.message
    no_torque = BenchData(bench.p_in, bench.p_out, bench.omega, bench.theta, bench.q, None)
    with pytest.raises(InputError) as err:
        check_losses(no_torque, D)
    assert err.value.field == "T"
    with pytest.raises(InputError) as err:
        check_losses(bench, -1.0)
    assert err.value.field == "D"
