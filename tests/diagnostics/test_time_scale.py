"""A measured cycle's clock checked by its piston (diagnostics.time_scale): a stroke faster
than the pump can drive, ≥ 30× slower, or a position that disagrees with its own speed
channel is a note naming the factor; a right clock is silent."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.observations import rig_limits
from diagnostics.time_scale import crossing_speed, time_scale_notes
from diagnostics.timeseries import SeriesRecord
from sim.rigs import reference_rig

#: the reference rig: ω·Vp = 167.55 rad/s × 2.785e-6 m³/rad over π/4·(60² − 30²) mm²
BOUND = 167.5516081914556 * 2.7852115041081685e-6 / (math.pi / 4 * (0.06**2 - 0.03**2))


def _stroke(speed: float, rate: float = 1000.0, noise: float = 0.0, seed: int = 0
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A piston held 0.2 s, out over 0.5 m at ``speed`` [m/s], held, and back: t, x, v."""
    run = 0.5 / speed
    t = np.arange(0.0, 2 * run + 0.6, 1.0 / rate)
    x = np.clip(np.minimum((t - 0.2) * speed, 0.5 - (t - 0.4 - run) * speed), 0.0, 0.5)
    v = np.gradient(x, t)
    x = x + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return t, x, v


def test_the_bound_is_the_pumps_delivery_over_the_smaller_chamber():
    drive = rig_limits(reference_rig())
    assert drive.max_piston_speed() == pytest.approx(BOUND, rel=1e-12)        # 0.2201 m/s
    assert drive.max_piston_speed(2 * drive.speed) == pytest.approx(2 * BOUND, rel=1e-12)
    # a rig without a cylinder has no limits to judge by: nothing is said
    t, x, _ = _stroke(0.16)
    assert time_scale_notes([SeriesRecord("r", t / 10, {"x": x}, {"x": "m"})], None) == []


@pytest.mark.parametrize("noise", [0.0, 0.005])   # 5 mm of position noise: 1 % of travel
def test_a_crossing_reads_the_pistons_speed(noise):
    t, x, _ = _stroke(0.16, noise=noise)
    # the fastest crossing leans on the noise by up to ~2 noise / 0.4 m
    assert crossing_speed(t, x) == pytest.approx(0.16, rel=0.05 if noise else 0.005)
    assert crossing_speed(t, np.full(t.size, 0.3)) is None            # no travel
    assert crossing_speed(t[:300], x[:300], 0.1) is None              # 16 mm of 0.5 m
    drive = rig_limits(reference_rig())
    dwell = SeriesRecord("dwell", t[:300], {"x": 0.5 + x[:300] - x[0]}, {"x": "m"})
    assert time_scale_notes([dwell], drive) == []   # noise at a stop crosses in a sample


def test_a_wrong_rate_is_named_and_a_right_one_is_silent():
    drive = rig_limits(reference_rig())
    t, x, _ = _stroke(0.16)
    right = SeriesRecord("right", t, {"x": x}, {"x": "m"})
    assert time_scale_notes([right], drive) == []
    # a 1 kHz logger imported as 10 kHz: the piston would cross at 7.3× the bound
    fast = SeriesRecord("fast", t / 10, {"x": x}, {"x": "m"})
    (note,) = time_scale_notes([fast], drive)
    assert "'fast'" in note and f"{1.6 / BOUND:.3g}×" in note and "too short" in note
    # a 100 Hz logger imported as 1 Hz: 100× too slow
    slow = SeriesRecord("slow", t * 100, {"x": x}, {"x": "m"})
    (note,) = time_scale_notes([slow], drive)
    assert "'slow'" in note and f"{100 * BOUND / 0.16:.3g}×" in note and "too long" in note
    # a pump stated at half speed bounds the piston at half the speed: 0.16 is too fast
    half = SeriesRecord("half", t, {"x": x}, {"x": "m"}, condition={"pump_speed": 60.0})
    assert "too short" in time_scale_notes([half], drive)[0]
    assert time_scale_notes([slow], None) == []                       # no drive: no word


def test_a_position_and_its_speed_channel_must_share_the_clock():
    drive = rig_limits(reference_rig())
    t, x, v = _stroke(0.16)
    both = SeriesRecord("both", t, {"x": x, "v": v}, {"x": "m", "v": "m/s"})
    assert time_scale_notes([both], drive) == []
    doubled = SeriesRecord("doubled", 2 * t, {"x": x, "v": v}, {"x": "m", "v": "m/s"})
    (note,) = time_scale_notes([doubled], drive)    # within the pump's bounds, not with v
    assert "'doubled'" in note and "0.5×" in note and "speed channel v" in note
    # a speed alone is a speed whatever the clock: nothing to judge
    alone = SeriesRecord("alone", 100 * t, {"v": v}, {"v": "m/s"})
    assert time_scale_notes([alone], drive) == []
