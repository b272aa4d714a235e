"""Readings of the accuracy study's transient generator, stalled strokes included."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from benchmarks.accuracy_cases import (
    IN_LIBRARY,
    differential_document,
    draw_fault,
    draw_truth,
    stated_condition,
    transient_readings,
)
from benchmarks.accuracy_report import miss_reasons
from diagnostics.diagnose import diagnose
from diagnostics.evidence import FLEET_PRIOR
from diagnostics.hypotheses import PARAMETERS
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
    # the best fit holds the piston on its end stop too (the steady model's end-stop
    # state), at the worn end of the prior, and cannot reach these pressures: the result
    # states the limit
    assert d.top.predicted[0]["speed_work"] == 0.0
    assert "Model limit" in d.to_dict()["misfit"] and "end stop" in d.to_dict()["misfit"]


def test_a_seal_worn_within_the_prior_that_stalls_is_explained_and_sized() -> None:
    """3.4 × the seal clearance (inside the prior) at 4.9 kN and 35 °C: the transient
    piston stalls on its end stop; the steady model's end-stop state explains the readings
    (before issue 11's end-stop state: "not explained", a model limit), names the seal
    and brackets its clearance."""
    rig = reference_rig()
    cc = 3.4 * rig.base["cylinder.cc"]
    tr = transient_readings(rig, {"cylinder.cc": cc}, 4921.0, 35.0)
    assert "working" in tr.stalled and tr.values["speed_work"] == 0.0
    cond = OperatingCondition.from_readings({"oil_temperature": 35.0, "load_force": 4921.0})
    rec = MeasurementRecord.from_readings(
        "stall", cond, {k: tr.values[k] for k in FULL if k in tr.values and k != "speed_work"})
    d = diagnose(rig, [rec])
    assert d.explained and d.top.name == "cylinder"
    assert d.top.predicted[0]["speed_work"] == 0.0
    (est,) = d.top.parameters
    assert est.low <= cc <= est.high
    assert d.to_dict()["misfit"] is None


def test_a_stated_condition_stays_within_its_instrument_bounds() -> None:
    rng = np.random.default_rng(1)
    pairs = [stated_condition(4.0e3, 50.0, rng) for _ in range(500)]
    loads, temps = np.array(pairs).T
    assert np.all(np.abs(loads - 4.0e3) <= 40.0) and np.all(np.abs(temps - 50.0) <= 1.0)
    # uniform within the bound: its standard deviation is a/√3
    assert np.std(temps) == pytest.approx(1 / np.sqrt(3), rel=0.1)


def test_in_library_draws_follow_the_diagnosis_prior() -> None:
    """Every drawn parameter lies in its worn prior range; the draw is uniform in the
    fitting coordinate (log for a clearance: half the draws below the geometric mean)."""
    rig = reference_rig()
    rng = np.random.default_rng(3)
    lo, hi = PARAMETERS["cc"].worn_bounds(rig)
    ccs = []
    for _ in range(400):
        ov, params = draw_fault(rig, "cylinder+pump", rng, beyond=False, pump_pressure=5e6)
        assert lo <= params["cc"] <= hi and ov["cylinder.cc"] == params["cc"]
        plo, phi = PARAMETERS["pump_leak"].worn_bounds(rig)
        assert plo <= params["pump_leak"] <= phi
        assert ov["pump.Rlp"] == pytest.approx(rig.base["pump.Rlp"] / params["pump_leak"])
        ccs.append(params["cc"])
    assert np.mean(np.array(ccs) < np.sqrt(lo * hi)) == pytest.approx(0.5, abs=0.08)
    assert draw_fault(rig, "healthy", rng, beyond=False, pump_pressure=5e6) == ({}, {})


def test_a_relief_setting_is_drawn_where_it_opens() -> None:
    rig = reference_rig()
    rng = np.random.default_rng(4)
    p_pump = 0.6 * rig.base["relief.Pset"]
    for _ in range(200):
        _, params = draw_fault(rig, "relief_setting", rng, beyond=False, pump_pressure=p_pump)
        assert PARAMETERS["Pset"].worn_bounds(rig)[0] <= params["Pset"] <= p_pump
        _, params = draw_fault(rig, "relief_setting", rng, beyond=True, pump_pressure=p_pump)
        assert params["Pset"] < PARAMETERS["Pset"].bounds(rig)[0]


def test_truths_follow_the_fleet_prior() -> None:
    rng = np.random.default_rng(5)
    counts = Counter(draw_truth(rng) for _ in range(9000))
    assert set(counts) == set(IN_LIBRARY)
    for t in IN_LIBRARY:
        assert counts[t] / 9000 == pytest.approx(FLEET_PRIOR[t], abs=0.015)


def test_a_miss_is_classified_by_its_reason() -> None:
    base = {"error": None, "top1_grouped": 0.0, "stalled": False, "explained": 1.0,
            "in_set": 1.0}
    rows = [base | {"stalled": True, "explained": 0.0}, base | {"explained": 0.0},
            base, base | {"in_set": 0.0}, base | {"top1_grouped": 1.0}]
    assert miss_reasons(rows) == {"stalled": 1, "unexplained": 1, "not_separable": 1,
                                  "rejected": 1}


def test_the_calibration_error_weights_each_decile_by_its_cases() -> None:
    from benchmarks.accuracy_figures import calibration_error

    # [lo, hi, n, mean stated p, observed]: |0.35-0.25|·2 + |0.95-1.0|·8 over 10 cases
    rel = [[0.3, 0.4, 2, 0.35, 0.25], [0.9, 1.0, 8, 0.95, 1.0]]
    assert calibration_error(rel) == pytest.approx((2 * 0.10 + 8 * 0.05) / 10)


def test_incipient_faults_lie_between_the_document_and_the_worn_range():
    """The incipient suite's draws: leakage × 1.1-1.33 (seat leak 0.1-0.33), i.e. past the
    document's value and short of the worn range where each hypothesis starts."""
    from benchmarks.accuracy_cases import INCIPIENT, draw_fault
    from diagnostics.hypotheses import PARAMETERS
    from sim.rigs import reference_rig

    rig = reference_rig()
    rng = np.random.default_rng(4)
    for truth in INCIPIENT:
        for _ in range(20):
            ov, params = draw_fault(rig, truth, rng, beyond=False, pump_pressure=1e7,
                                    incipient=True)
            ((name, value),) = params.items()
            par = PARAMETERS[name]
            worn_start = par.worn_bounds(rig)[0]
            assert par.nominal_value(rig) < value < worn_start
            leak = (value / par.nominal_value(rig)) ** 3 if name in ("cc", "cv") else value
            assert (0.1 if name == "seat_leak" else 1.1) <= leak <= 1.33
            assert ov == {par.graph_param: par.graph_value(rig, value)}
