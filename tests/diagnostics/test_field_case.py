"""The paper-000 case end to end on SIMULATED field records (diagnostics.pump.field_record):
the workflow names the hidden side-plate lag, adds it, fits τ and the held-out gap after
the pressure steps shrinks; without a hidden effect nothing is named."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.discrepancy.field_case import HELD_OUT_LR, after_steps, discover_field
from diagnostics.pump.field_record import HiddenEffects, generate_field_record
from sim.duty_cycle import rpm


def _records(effects: HiddenEffects, seed: int):
    train = [generate_field_record(60.0, effects=effects, seed=seed + k) for k in (0, 1)]
    # held out: the edge of the operating range (the fastest field speed of paper 000)
    held = generate_field_record(60.0, effects=effects, seed=seed + 2, speed=rpm(1961))
    return train, held


def test_a_hidden_side_plate_lag_is_named_fitted_and_the_gap_after_steps_shrinks():
    train, held = _records(HiddenEffects(side_plate_lag=0.3), 11)
    d = discover_field(train, held)
    assert d.verdict == "named" and d.named == ["side_plate_lag"]
    tau, u = d.fitted["side_plate_lag.tau"], d.errors["side_plate_lag.tau"]
    assert abs(tau - 0.3) < max(3 * u, 0.03)
    assert d.start["side_plate_lag.tau"] == pytest.approx(0.3, rel=0.3)  # equation error
    assert d.held_out_lr > HELD_OUT_LR
    g = d.gap("after steps")
    assert g.samples > 200
    # against the noise-free flow the gap after the steps shrinks many times; the measured
    # RMSE shrinks too, but only a little: the lag is ≈ 0.2 σ of the ±1 % flowmeter
    assert g.truth_before > 5 * g.truth_after
    assert g.rmse_after < g.rmse_before and g.max_after < g.max_before
    # the steady part was explained already
    assert d.gap("steady").truth_before < 0.1 * g.truth_before
    assert d.to_dict()["named"] == ["side_plate_lag"]


def test_without_a_hidden_effect_nothing_is_named():
    train, held = _records(HiddenEffects(), 21)
    d = discover_field(train, held)
    assert d.verdict == "no effect" and d.named == []
    assert d.gap("all").truth_before < 1e-7          # the base model is the truth here


def test_steps_are_found_where_the_pressure_moves_fast():
    rec = generate_field_record(20.0, seed=4)
    mask = after_steps(rec)
    dp = np.gradient(rec.pressure, rec.t)
    assert mask[np.argmax(np.abs(dp))]
    assert 0.1 < mask.mean() < 0.9
