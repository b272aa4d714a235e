"""Test-design plumbing of the discrepancy workflow: timed (slow-motion) strokes, the
held-out split per kind of stroke, the headline RMSE ratio and the steady flow model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.discrepancy.first_step import split
from diagnostics.discrepancy.gap import GapRow
from diagnostics.discrepancy.simulate import simulate_record, timed_switch
from diagnostics.discrepancy.steady import predict_flow
from diagnostics.discrepancy.synthetic import NOISE, synthesize, synthesize_bench
from diagnostics.discrepancy.verdict import gap_ratio
from diagnostics.timeseries import SeriesRecord
from sim.components.effects import EFFECTS
from sim.rigs import reference_rig, reference_rig_document
from sim.rigs.assembly import Condition

#: stated pump speed of the reference rig [rad/s]
SPEED = 1600.0 * 2.0 * math.pi / 60.0
ZERO = dict.fromkeys(NOISE, 0.0)


def _slow(load: float, temp: float, switch: float) -> SeriesRecord:
    rig = reference_rig()
    cond = Condition(load=load, oil_temperature=temp, pump_speed=0.15 * SPEED)
    return synthesize(rig, cond, rng=np.random.default_rng(0), name=f"slow {load:.0f} {temp:.0f}",
                      sigma=ZERO, t_max=switch)


def _full(load: float, temp: float) -> SeriesRecord:
    rig = reference_rig()
    cond = Condition(load=load, oil_temperature=temp)
    return synthesize(rig, cond, rng=np.random.default_rng(0), name=f"full {load:.0f} {temp:.0f}",
                      sigma=ZERO)


def test_a_slow_stroke_switched_by_time_is_simulated_with_the_same_switch() -> None:
    rig = reference_rig()
    rec = _slow(2100.0, 40.0, 1.0)
    # the piston at 15 % pump speed covers ≈ 2 cm in 1 s: far from the 0.5 m stroke end
    work = rec.phase == "working"
    assert rec.channels["x"][work][-1] < 0.05
    switch = timed_switch(rec, rig)
    assert switch is not None and abs(switch - 1.0) <= 2e-3
    table = simulate_record(rig, rec)
    t_work = table.loc[table["phase"] == "working", "t [s]"].to_numpy()
    assert abs(t_work[-1] - switch) <= 1e-3
    # the model's position at the switch is the record's (same rig, noise-free): < 0.1 mm
    x_end = float(table.loc[table["phase"] == "working", "x [m]"].iloc[-1])
    assert abs(x_end - float(rec.channels["x"][work][-1])) < 1e-4


def test_a_full_stroke_is_switched_by_the_end_stop_and_a_record_without_x_is_not_timed() -> None:
    rig = reference_rig()
    rec = _full(2100.0, 40.0)
    assert timed_switch(rec, rig) is None
    no_x = SeriesRecord("no x", rec.t, {k: v for k, v in rec.channels.items() if k != "x"},
                        {k: u for k, u in rec.units.items() if k != "x"}, rec.phase,
                        rec.condition, measured=False)
    assert timed_switch(no_x, rig) is None


def test_the_edge_record_of_each_kind_of_stroke_is_held_out() -> None:
    rig = reference_rig()
    records = [_full(2100.0, 40.0), _full(6300.0, 60.0), _full(4200.0, 50.0),
               _slow(2100.0, 40.0, 0.5), _slow(2100.0, 60.0, 0.5)]
    train, held, notes = split(records, rig)
    assert held == [1, 4]
    assert train == [0, 2, 3] and notes == []
    # one full stroke and one slow stroke: only the full-speed edge can be held out
    train, held, _ = split([records[0], records[1], records[3]], rig)
    assert held == [1] and train == [0, 2]


def test_every_repeat_of_the_edge_condition_is_held_out_with_it() -> None:
    """The held-out check extrapolates to the edge: a repeat of the edge record's condition
    left in training made it an interpolation (a design pass: loads 2.1/2.1/4.2/4.2/6.3/6.3
    kN held out one 6.3 kN record and trained on its twin); a design of one condition,
    repeated, holds one record out and says the check interpolates."""
    rig = reference_rig()
    loads = (2100.0, 2100.0, 4200.0, 4200.0, 6300.0, 6250.0)
    records = [_full(load, 50.0 + 0.5 * (i % 2)) for i, load in enumerate(loads)]
    train, held, notes = split(records, rig)
    assert held == [4, 5] and train == [0, 1, 2, 3] and notes == []
    # at the top load, 60 °C repeats the 61 °C edge; 50 °C is another condition
    records = [_full(2100.0, 40.0), _full(6300.0, 50.0), _full(6300.0, 60.0),
               _full(6300.0, 61.0)]
    train, held, notes = split(records, rig)
    assert held == [2, 3] and train == [0, 1]
    same = [_full(4200.0, 50.0), _full(4200.0, 50.0), _full(4200.0, 50.5)]
    train, held, notes = split(same, rig)
    assert held == [2] and train == [0, 1]
    assert len(notes) == 1 and "interpolates" in notes[0] and "4200 N" in notes[0]
    # three repeats of four: all out would leave one record to train on (a verification
    # pass: a hidden seal friction went unnamed), so the edge alone is held out
    most = [_full(2100.0, 40.0), _full(6300.0, 60.0), _full(6300.0, 60.0), _full(6300.0, 60.5)]
    train, held, notes = split(most, rig)
    assert held == [3] and train == [0, 1, 2]
    assert len(notes) == 1 and "3 of the 4" in notes[0] and "interpolates" in notes[0]


def _row(channel: str, rmse: float, region: str = "steady") -> GapRow:
    return GapRow(channel, "Pa", region, rmse, rmse)


def test_gap_ratio_is_taken_on_the_channel_with_the_largest_gap_in_noise_units() -> None:
    sigma = {"P1": 5e3, "Q_meter_B": 1e-6}
    # P1: 4 σ before in both records; the flow 2 σ; an after-step row does not count
    before = [_row("P1", 20e3), _row("P1", 20e3), _row("Q_meter_B", 2e-6),
              _row("Q_meter_B", 2e-6), _row("P1", 1e9, "after step")]
    after = [_row("P1", 4e3), _row("P1", 2e3), _row("Q_meter_B", 1e-6), _row("Q_meter_B", 1e-6)]
    # P1 is the worst (4 σ vs 2 σ); after, pooled √((4e3² + 2e3²)/2) = √10e6
    assert gap_ratio(before, after, sigma) == pytest.approx(20e3 / math.sqrt(10e6), rel=1e-12)
    # a smaller flow σ makes the flow channel the worst: 2e-6 / 1e-6 = 2
    assert gap_ratio(before, after, {"P1": 5e3, "Q_meter_B": 1e-7}) == pytest.approx(2.0)
    assert gap_ratio(before, [], sigma) != gap_ratio(before, [], sigma)  # nan: nothing after


def test_predict_flow_is_the_bench_truth_with_and_without_an_effect() -> None:
    rig = reference_rig()
    doc = reference_rig_document()
    v = rig.values()
    clean = synthesize_bench(rig, rng=np.random.default_rng(0), sigma_q=0.0, sigma_p=0.0)
    # hand calculation of the stored pump: q = ω·Vp − Δp/Rlp
    hand = clean.omega * v["pump.Vp"] - clean.p_out / v["pump.Rlp"]
    assert np.allclose(predict_flow(doc, clean), hand, rtol=1e-12, atol=0.0)
    name = "turbulent_pump_slip"
    k = EFFECTS[name].entry.plausible[1] / 10
    truth = synthesize_bench(rig, rng=np.random.default_rng(0), effects={name: k},
                             sigma_q=0.0, sigma_p=0.0)
    pred = predict_flow(doc, truth, {name: k})
    assert np.allclose(pred, truth.q, rtol=1e-12, atol=0.0)
    assert float(np.max(np.abs(pred - hand))) > 0.0
