"""The clock on which the workflow compares a record with its model, and the re-fits' errors
(``diagnostics/discrepancy/simulate.py`` :func:`phase_start`, ``refit.py``
:func:`residual_parts`, :func:`fit_cov`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.discrepancy.refit import NUMERICAL, fit_cov, residual_parts
from diagnostics.discrepancy.simulate import model_phase_start, phase_start, simulate
from diagnostics.discrepancy.synthetic import NOISE, synthesize
from sim.rigs import Condition, reference_rig

SPEED = 1600.0 * math.pi / 30.0


def test_a_phase_starts_midway_before_its_first_sample() -> None:
    t = np.arange(0.0, 0.01, 0.001)
    assert phase_start(t, 0) == 0.0
    assert phase_start(t, 4) == pytest.approx(0.0035)


def test_the_model_clock_starts_at_the_switch_event_not_its_first_grid_row() -> None:
    table = simulate(reference_rig(), Condition(load=4200.0))
    rows = table[table["phase"] == "return"]["t [s]"].to_numpy()
    switch = model_phase_start(table, "return")
    # the grid's first return row is within one 5 kHz period after the event
    assert 0.0 <= rows[0] - switch < 2e-4 + 1e-12
    assert model_phase_start(table, "working") == 0.0


def test_a_noise_free_record_matches_its_own_model_to_the_solver_accuracy() -> None:
    """Sampled at 1 kHz, the switch anywhere within a sample: each phase placed within its
    sample, the truth's residual is the solver's, far below the noise (the position was
    0.41 σ RMS off when each phase started at its first sample)."""
    rig = reference_rig()
    cc = rig.values()["cylinder.cc"]
    truth = {"cylinder.cc": 1.2 * cc}
    rng = np.random.default_rng(11)
    records = []
    for load, temp, f in ((2100.0, 40.0, 0.8), (4200.0, 50.0, 0.9)):
        cond = Condition(load=load, oil_temperature=temp, pump_speed=f * SPEED)
        r = synthesize(rig, cond, rng=rng, overrides=truth, sigma=dict.fromkeys(NOISE, 0.0))
        r.condition.update(load=load, oil_temperature=temp, pump_speed=f * SPEED)
        records.append(r)
    channels = [c for c in NOISE if c in records[0].channels]
    parts = residual_parts(rig, records, channels, dict(NOISE), truth)
    for c in channels:
        rms = float(np.sqrt(np.mean(np.concatenate([p for ch, p in parts if ch == c]) ** 2)))
        assert rms < 0.02, c
    # a clearance 1 % off is seen far above that
    off = residual_parts(rig, records, channels, dict(NOISE), {"cylinder.cc": 1.212 * cc})
    assert sum(float(p @ p) for _, p in off) > 100 * sum(float(p @ p) for _, p in parts)


def test_a_re_fit_error_is_never_finer_than_the_solver_resolution() -> None:
    """Residuals of pure noise over 4,000 samples: the Jacobian alone states 1/√n of a
    parameter that moves the outputs 1 σ per unit; the largest change an error of the
    solver of NUMERICAL σ at every sample could cause is wider and is what is stated."""
    rng = np.random.default_rng(3)
    n = 4000
    J = np.ones((n, 1))
    r = rng.normal(0.0, 1.0, n)
    var = fit_cov(J, r, [n // 4] * 4)[0, 0]
    assert math.sqrt(var) == pytest.approx(NUMERICAL, rel=1e-9)
    assert math.sqrt(var) > 5.0 / math.sqrt(n)
    # a signature in 400 of the samples, 2 σ per unit there: an error of NUMERICAL σ at
    # each of them moves the parameter by at most NUMERICAL / 2
    J = np.zeros((n, 1))
    J[:400] = 2.0
    var = fit_cov(J, r, [n // 4] * 4)[0, 0]
    assert math.sqrt(var) == pytest.approx(NUMERICAL / 2.0, rel=1e-9)
