"""Accumulator pre-charge where it empties: hand calculations, a synthetic round trip, a slice."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from diagnostics.real.accumulator import LoadStep, step_volumes
from diagnostics.real.precharge import fit_precharge, refer_precharge, stored_volume
from diagnostics.real.zema import load_1hz, read_records
from sim.errors import InputError
from tests.real_slices import zema_program_slice

BAR = 1.0e5


def test_stored_volume_by_hand() -> None:
    # isothermal (n = 1), 1 l, filled to 100 bar: at 200 bar half the gas is left
    assert float(stored_volume(100 * BAR, 200 * BAR, 100 * BAR, 1e-3, n=1.0)) == \
        pytest.approx(0.5e-3)
    assert float(stored_volume(200 * BAR, 100 * BAR, 100 * BAR, 1e-3, n=1.0)) == \
        pytest.approx(-0.5e-3)
    # below the pre-charge the accumulator is empty: nothing stored
    assert float(stored_volume(50 * BAR, 80 * BAR, 100 * BAR, 1e-3)) == 0.0
    # a step across p0 stores only above it: (1 − (100/150)^(1/1.4)) of V0
    assert float(stored_volume(80 * BAR, 150 * BAR, 100 * BAR, 1e-3)) == \
        pytest.approx(1e-3 * (1.0 - (100.0 / 150.0) ** (1.0 / 1.4)))


def test_refer_precharge_is_the_ideal_gas_at_constant_volume() -> None:
    assert float(refer_precharge(146.0 * BAR, 56.0, 20.0)) == \
        pytest.approx(146.0 * BAR * 293.15 / 329.15)
    assert float(refer_precharge(120.0 * BAR, 20.0)) == pytest.approx(120.0 * BAR)


def _steps(p0: float, v0: float, levels: list[float], noise: float,
           rng: np.random.Generator) -> list[LoadStep]:
    out = []
    for t, (a, b) in enumerate(itertools.pairwise(levels)):
        dv = float(stored_volume(a, b, p0, v0)) + rng.normal(0.0, noise)
        out.append(LoadStep(a, b, dv, float(t)))
    return out


def test_volume_and_precharges_come_back_from_a_synthetic_campaign() -> None:
    rng = np.random.default_rng(11)
    v0 = 0.6e-3
    # the ZeMA program's plateaus, lower in hot oil; fills that empty on the lower plateaus
    # (147 bar) identify V0 apart from p0
    truth = rng.choice([110.0, 122.0, 136.0, 147.0], 400) * BAR
    shift = rng.uniform(0.0, 5.0, truth.size) * BAR
    steps: list[list[LoadStep] | None] = [
        _steps(p, v0, [146 * BAR - s, 156 * BAR - s, 166 * BAR - s, 156 * BAR - s,
                       151 * BAR - s], 0.5e-6, rng)
        for p, s in zip(truth, shift, strict=True)]
    steps[3] = None  # a cycle without steps is left out
    fit = fit_precharge(steps)
    assert fit.v0 == pytest.approx(v0, rel=0.03)
    assert np.isnan(fit.p0[3])
    ok = np.isfinite(fit.p0)
    for p in np.unique(truth):
        m = ok & (truth == p)
        assert float(np.median(fit.p0[m])) == pytest.approx(float(p), abs=1.5 * BAR)
    assert fit.rms == pytest.approx(0.5e-6, rel=0.3)
    with pytest.raises(InputError):
        fit_precharge(steps[:2])
    with pytest.raises(InputError):
        fit_precharge([steps[0], steps[1], steps[2][:3] if steps[2] else None])
    with pytest.raises(InputError):
        fit_precharge(steps, p0_min=200 * BAR, p0_max=100 * BAR)


def test_precharge_orders_the_fills_on_the_slice() -> None:
    data, labels = load_1hz(zema_program_slice())
    recs = read_records(data)
    steps = [step_volumes(r, relaxation=3.5) for r in recs]
    fit = fit_precharge([s if len(s) == 4 else None for s in steps])
    theta = np.array([float(np.mean(r.channel("oil_temperature"))) for r in recs])
    p20 = refer_precharge(fit.p0, theta)
    med = [float(np.nanmedian(p20[labels.accumulator == a])) for a in (90, 100, 115, 130)]
    assert all(x < y for x, y in itertools.pairwise(med))
    assert fit.v0 > 0.0
