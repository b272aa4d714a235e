"""The workflow's reading of records: a speed derived from a position-only logger, and
notes on what the channels do not allow (a simulation engineer's pass)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from diagnostics.discrepancy.first_step import OUTPUTS, check_records
from diagnostics.discrepancy.records import unread_notes, with_velocity
from diagnostics.discrepancy.synthetic import synthesize
from diagnostics.timeseries import SeriesRecord
from sim.rigs import reference_rig, reference_rig_document
from sim.rigs.assembly import Condition


def _without(record: SeriesRecord, *names: str) -> SeriesRecord:
    keep = {k: v for k, v in record.channels.items() if k not in names}
    return dataclasses.replace(record, channels=keep,
                               units={k: u for k, u in record.units.items() if k in keep})


def test_a_position_only_loggers_speed_is_the_positions_derivative() -> None:
    """A linear encoder (0.1 mm noise at 1 kHz) without a speed channel: ``v`` is the
    cubic Savitzky-Golay derivative of ``x`` within each phase.  Its noise is the filter's
    gain on the position noise — for a cubic first derivative over 2m+1 = 41 samples
    √(75(3m⁴+6m³−3m+1)/((2m−1)(2m+1)(2m+3)(m−1)m(m+1)(m+2))) = 0.057, so 0.1 mm / 1 ms ×
    0.057 = 5.7 mm/s — and the mean speed of a stroke is unbiased."""
    rig = reference_rig()
    cond = Condition(load=2100.0, oil_temperature=40.0)
    truth = synthesize(rig, cond, rng=np.random.default_rng(0),
                       sigma=dict.fromkeys(("x", "v"), 1e-12))
    noisy = _without(synthesize(rig, cond, rng=np.random.default_rng(1)), "v")
    (derived,), notes = with_velocity([noisy])
    assert "v" in derived.channels and derived.units["v"] == "m/s"
    assert "derived from the position x" in notes[0]
    v, true_v = derived.channels["v"], truth.channels["v"]
    assert v.shape == true_v.shape
    steady = (np.abs(true_v) > 0.1) & (np.abs(np.gradient(true_v, truth.t)) < 0.05)
    assert steady.sum() > 1000
    error = v[steady] - true_v[steady]
    assert float(np.sqrt(np.mean(error ** 2))) < 5.7e-3
    # the working stroke's mean speed: the hand value of 0.2064 m/s at 2.1 kN, 40 °C
    working = steady & (derived.phase == "working")
    assert float(np.mean(v[working])) == pytest.approx(float(np.mean(true_v[working])),
                                                       rel=2e-3)
    # a record with its own speed is left as it is
    (kept,), none = with_velocity([truth])
    assert kept is truth and none == []


def test_missing_and_unread_channels_are_named_not_dropped_silently() -> None:
    """A file whose P1 column is named 'P_A' was checked on the pump balance alone and
    answered "no effect"; now the answer says which balances were not evaluated, for want
    of which channel, and which columns it did not read."""
    rig = reference_rig()
    record = synthesize(rig, Condition(load=2100.0, oil_temperature=40.0),
                        rng=np.random.default_rng(2))
    renamed = dataclasses.replace(
        _without(record, "P1"), channels=_without(record, "P1").channels
        | {"P_A": record.channels["P1"]}, units=_without(record, "P1").units | {"P_A": "Pa"})
    notes = unread_notes([renamed], ["pump_flow"], OUTPUTS)
    text = " ".join(notes)
    assert "piston_force (no P1)" in text and "chamber_flow (no P1)" in text
    assert "'P_A' not read" in text
    assert "covers only the balances evaluated" in text
    # a position-only record passes the first step with the piston balances evaluated
    check_records(reference_rig_document(), [_without(record, "v")])


@pytest.mark.parametrize(("channel", "scale", "why"), [
    ("Q_meter_C", 60000.0, "l/min"), ("Q_meter_B", 60000.0, "l/min"),
    ("x", 1000.0, "mm under an [m] label"), ("v", -1.0, "sign flipped"),
    ("Q_meter_C", -1.0, "against the piston's motion"),
    ("Q_meter_B", -1.0, "negative while the piston moves")])
def test_a_flow_position_or_speed_its_column_contradicts_is_refused(
        channel: str, scale: float, why: str) -> None:
    """l/min under ``[m^3/s]`` (60,000× the pump's flow), mm under ``[m]``, a flipped
    speed and a flipped flow meter were run and answered "unexplained … re-commission" at
    10²-10⁶ σ (a simulation engineer's pass): each is refused naming its column, and the record as exported
    passes (its first sample's flow transient, ~3× the pump's, included)."""
    from sim.errors import InputError

    rig = reference_rig()
    record = synthesize(rig, Condition(load=2100.0, oil_temperature=40.0),
                        rng=np.random.default_rng(3))
    check_records(reference_rig_document(), [record])
    bad = dataclasses.replace(record, channels=record.channels
                              | {channel: record.channels[channel] * scale})
    with pytest.raises(InputError) as refused:
        check_records(reference_rig_document(), [bad])
    assert refused.value.field == channel and why in refused.value.message


def test_a_reversed_encoder_without_a_speed_channel_is_named_as_the_position() -> None:
    """A position-only file with the encoder counting the other way was refused naming
    'v', a column the file does not have (a checker's pass)."""
    from sim.errors import InputError

    record = synthesize(reference_rig(), Condition(load=2100.0, oil_temperature=40.0),
                        rng=np.random.default_rng(4))
    bare = _without(record, "v")
    reversed_x = dataclasses.replace(bare, channels=bare.channels
                                     | {"x": 0.5 - bare.channels["x"]})
    with pytest.raises(InputError) as refused:
        check_records(reference_rig_document(), [reversed_x])
    assert refused.value.field == "x" and "position's sign" in refused.value.message


def test_a_pressure_in_bar_under_pa_and_a_load_in_kn_under_n_are_refused() -> None:
    """P2 in bar under ``[Pa]`` and a load of 2.1 "N" ran to "unexplained" at 2.9e6 σ and
    397 σ (a simulation engineer's pass): refused naming P2 and the load; a record held
    at its stop (P1 at the relief setting) with its true load passes."""
    from sim.errors import InputError

    record = synthesize(reference_rig(), Condition(load=2100.0, oil_temperature=40.0),
                        rng=np.random.default_rng(5))
    p2_bar = dataclasses.replace(record, channels=record.channels
                                 | {"P2": record.channels["P2"] / 1e5})
    with pytest.raises(InputError) as refused:
        check_records(reference_rig_document(), [p2_bar])
    assert refused.value.field == "P2" and "never reaches 0.1 bar" in refused.value.message
    kn = dataclasses.replace(record, condition=record.condition | {"load": 2.1})
    with pytest.raises(InputError) as load:
        check_records(reference_rig_document(), [kn])
    assert load.value.field == "load" and "in kN" in load.value.message
    # the hidden-effect bench's dwell records, each held ~1.5 s at the stop
    from diagnostics.discrepancy.synthetic import DWELLS

    rig = reference_rig()
    speed = rig.base["pump.speed"]
    dwells = [synthesize(rig, Condition(load=L, oil_temperature=T, pump_speed=f * speed),
                         rng=np.random.default_rng(6), t_max=switch, name=f"dwell-{i}")
              for i, (L, T, f, switch) in enumerate(DWELLS)]
    check_records(reference_rig_document(), dwells)


def test_a_cycle_on_a_wrong_clock_is_said_in_the_workflows_notes() -> None:
    """A 1 kHz cycle uploaded as 100 Hz (its times ×10) moves its piston at a tenth of the
    speed its own v channel reads: the workflow's notes say so (diagnostics.time_scale),
    as the import does; the record at its own clock adds no such note."""
    from diagnostics.discrepancy.first_step import first_step

    rig = reference_rig()
    record = synthesize(rig, Condition(load=2100.0, oil_temperature=40.0),
                        rng=np.random.default_rng(2))
    right = first_step(reference_rig_document(), [record]).notes
    assert not any("crosses its travel" in n or "speed channel v" in n for n in right)
    slow = dataclasses.replace(record, t=record.t * 10.0)
    notes = " ".join(first_step(reference_rig_document(), [slow]).notes)
    assert "speed channel v" in notes and "0.1×" in notes


def test_discover_names_an_argument_of_the_wrong_type() -> None:
    """A compiled Rig, a file's path or one record alone raised a bare TypeError or
    ValueError (a library user's pass): the tree's error, naming the argument."""
    from diagnostics.discrepancy import discover
    from diagnostics.discrepancy.steady import discover_steady
    from sim.errors import InputError

    one = SeriesRecord("c", np.array([0.0, 1.0]), {"P1": np.array([1e6, 1e6])}, {"P1": "Pa"})
    doc = reference_rig_document()
    for rig_document, records, field, words in (
            (reference_rig(), [one], "rig_document", "rig.spec.to_document()"),
            ("press.yaml", [one], "rig_document", "load_rig_document(path)"),
            (doc, one, "records", "[record]"),
            (doc, [{"P1": 1e6}], "records[0]", "SeriesRecord"),
            # no record: named "file", the upload's field, not the argument (a review's
            # leftover), as diagnose(rig, []) names "records"
            (doc, [], "records", "at least one measured cycle"),
            (doc, (), "records", "no records to analyse")):
        with pytest.raises(InputError) as caught:
            discover(rig_document, records)  # type: ignore[arg-type]
        assert caught.value.field == field and words in caught.value.message
    with pytest.raises(InputError) as caught:
        discover_steady(reference_rig(), None)  # type: ignore[arg-type]
    assert caught.value.field == "rig_document"
