"""Readings of the accuracy study's transient generator, stalled strokes included."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.accuracy_cases import differential_document, stated_condition, transient_readings
from diagnostics.diagnose import diagnose
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from sim.rigs import load_rig, reference_rig
from tests.diagnostics.synth import FULL


def test_a_healthy_cycle_completes_and_its_ratio_is_the_speed_quotient() -> None:
    tr = transient_readings(reference_rig(), {}, 4.2e3, 40.0)
    assert tr.stalled == ()
    v = tr.values
    assert v["velocity_ratio"] == pytest.approx(v["speed_work"] / v["speed_return"])


@pytest.mark.parametrize("rig_name", ["preset", "differential"])
def test_a_seal_worn_beyond_the_prior_stalls_and_is_answered_not_explained(rig_name: str
                                                                            ) -> None:
    rig = reference_rig() if rig_name == "preset" else load_rig(differential_document())
    ov = {"cylinder.cc": 5.0 * rig.base["cylinder.cc"]}
    tr = transient_readings(rig, ov, 5.0e3, 60.0)
    assert "working" in tr.stalled
    v = tr.values
    # the settled stall: the pump's flow goes through the seal, so the meters read
    # forward flows and meter B carries meter C plus the valve leak (continuity)
    assert v["flow_C"] > 0.0
    assert v["flow_B"] >= v["flow_C"]
    # a stroke that did not complete leaves no return stroke to time, and no ratio
    assert "speed_return" not in v and "velocity_ratio" not in v
    cond = OperatingCondition.from_readings({"oil_temperature": 60.0, "load_force": 5.0e3})
    rec = MeasurementRecord.from_readings("stall", cond, {k: v[k] for k in FULL if k in v})
    d = diagnose(rig, [rec])
    assert not d.explained
    assert d.to_dict()["top"] == "unexplained"


def test_a_stated_condition_stays_within_its_instrument_bounds() -> None:
    rng = np.random.default_rng(1)
    pairs = [stated_condition(4.0e3, 50.0, rng) for _ in range(500)]
    loads, temps = np.array(pairs).T
    assert np.all(np.abs(loads - 4.0e3) <= 40.0) and np.all(np.abs(temps - 50.0) <= 1.0)
    # uniform within the bound: its standard deviation is a/√3
    assert np.std(temps) == pytest.approx(1 / np.sqrt(3), rel=0.1)
