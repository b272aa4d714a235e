"""Ranking of faulty components: single faults rank first, healthy ranks healthy."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.diagnose import diagnose
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from sim.errors import MeasurementError
from sim.rigs import reference_rig
from tests.diagnostics.synth import FULL, NO_FLOW, RATIO, record

LOADS = (2.1e3, 4.2e3, 6.3e3)
FAULTS = {
    "cylinder": ({"cylinder.cc": 120e-6}, "cc", 120e-6),
    "valve": ({"valve.cv": 60e-6}, "cv", 60e-6),
    "pump": ({"pump.Rlp": 6.0e11 / 3}, "pump_leak", 3.0),
}


@pytest.fixture(scope="module")
def rig():
    return reference_rig()


@pytest.mark.parametrize("load", LOADS)
def test_healthy_rig_ranks_healthy(rig, load):
    d = diagnose(rig, [record(rig, {}, load=load)])
    assert d.top.name == "healthy"


@pytest.mark.parametrize("load", LOADS)
@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_each_single_fault_ranks_first_and_is_recovered(rig, fault, load):
    overrides, pname, truth = FAULTS[fault]
    # pump leakage and a relief-seat leak move these readings the same way (stated as
    # parallel signatures); the pump-outlet flow meter separates them
    fields = (*FULL, "pump_flow") if fault == "pump" else FULL
    d = diagnose(rig, [record(rig, overrides, load=load, fields=fields)])
    assert d.top.name == fault
    (est,) = d.top.parameters
    assert est.name == pname
    assert est.low <= truth <= est.high
    assert est.value == pytest.approx(truth, rel=0.01)
    assert est.severity in ("mild", "moderate", "severe")


def test_pair_of_faults_ranks_the_pair(rig):
    d = diagnose(rig, [record(rig, {"cylinder.cc": 110e-6, "valve.cv": 50e-6})])
    assert d.top.name == "cylinder+valve"
    got = {p.name: p.value for p in d.top.parameters}
    assert got["cc"] == pytest.approx(110e-6, rel=0.01)
    assert got["cv"] == pytest.approx(50e-6, rel=0.01)


def test_records_at_three_loads_are_diagnosed_jointly(rig):
    rng = np.random.default_rng(3)
    recs = [record(rig, {"cylinder.cc": 105e-6}, load=f, fields=NO_FLOW, rng=rng) for f in LOADS]
    joint = diagnose(rig, recs)
    single = diagnose(rig, recs[:1])
    assert joint.top.name == "cylinder"
    assert joint.n_records == 3
    (j,) = joint.top.parameters
    assert j.low <= 105e-6 <= j.high
    width_single = single.hypotheses[[f.name for f in single.hypotheses].index("cylinder")]
    (s,) = width_single.parameters
    assert (j.high - j.low) < (s.high - s.low)


def test_probabilities_are_a_distribution(rig):
    d = diagnose(rig, [record(rig, {"valve.cv": 45e-6}, fields=NO_FLOW)])
    probs = [f.probability for f in d.hypotheses if f.observable]
    assert sum(probs) == pytest.approx(1.0)
    assert all(0.0 <= p <= 1.0 for p in probs)
    assert d.hypotheses == sorted(d.hypotheses, key=lambda f: (not f.observable, -f.probability,
                                                               len(f.hypothesis.parameters)))


def test_ratio_alone_is_honest_about_what_it_cannot_tell(rig):
    d = diagnose(rig, [record(rig, {"cylinder.cc": 120e-6}, fields=RATIO)])
    amb = set(d.isolability.ambiguity_set)
    assert {"cylinder", "valve"} <= amb
    assert "healthy" not in amb
    assert d.ratio is not None
    inv = {i.component: i for i in d.ratio.inversions}
    assert inv["cylinder"].value == pytest.approx(120e-6, rel=0.005)
    assert inv["cylinder"].sensitivity < 0 and inv["valve"].sensitivity < 0
    assert "cannot name the component" in d.ratio.statement
    assert any("flow_C" in s or "flow_B" in s for s in d.isolability.statements)


def test_relief_setting_is_reported_unobservable_at_these_loads(rig):
    d = diagnose(rig, [record(rig, {"relief.Pset": 0.9 * 7.0e6})])
    assert "relief_setting" in d.isolability.not_observable
    assert d.top.name == "healthy"
    assert any("end stop" in s for s in d.isolability.statements)


def test_pump_and_relief_seat_leak_are_flagged_inseparable_without_pump_flow(rig):
    d = diagnose(rig, [record(rig, {"relief.Gseat": 2.0 / 6.0e11})])
    assert {"pump", "relief_seat"} <= set(d.isolability.ambiguity_set)
    assert any({a, b} == {"pump", "relief_seat"} for a, b, _ in d.isolability.parallel)
    with_pump_flow = diagnose(rig, [record(rig, {"relief.Gseat": 2.0 / 6.0e11},
                                           fields=(*FULL, "pump_flow"))])
    assert with_pump_flow.top.name == "relief_seat"


def test_impossible_records_are_refused_with_the_field(rig):
    cond = OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": 2100.0})
    too_fast = MeasurementRecord.from_readings("r", cond, {"speed_work": 0.5})
    with pytest.raises(MeasurementError) as exc:
        diagnose(rig, [too_fast])
    assert exc.value.field == "speed_work"
    with pytest.raises(MeasurementError) as exc:
        MeasurementRecord.from_readings("r", cond, {"flow_B": -1e-4})
    assert exc.value.field == "flow_B"
    with pytest.raises(MeasurementError) as exc:
        MeasurementRecord.from_readings("r", cond, {"flow_B": float("nan")})
    assert exc.value.field == "flow_B"
    ok = MeasurementRecord.from_readings("r", cond, {"speed_work": 0.2})
    with pytest.raises(MeasurementError) as exc:
        diagnose(rig, [ok, too_fast])
    assert exc.value.field == "records[1].speed_work"


def test_result_serialises_with_units(rig):
    import json

    d = diagnose(rig, [record(rig, {"valve.cv": 50e-6})])
    doc = json.loads(json.dumps(d.to_dict()))
    assert doc["top"] == "valve"
    assert doc["observable_units"]["flow_B"] == "m^3/s"
    assert doc["direct_inversions"]["cv"]["unit"] == "m"
    assert doc["hypotheses"][0]["parameters"][0]["unit"] == "m"


def test_a_pair_whose_ridge_crosses_both_axes_has_the_evidence_of_its_quadrature() -> None:
    """One reading (the velocity ratio) and two parameters: the likelihood of
    cylinder+valve is a thin ridge across both axes in a corner of the prior square, where
    JᵀJ is singular and the bound-truncated Laplace value understates the evidence by
    orders of magnitude.  The ranking's value must agree with a 41 × 41 trapezoid
    quadrature of exp(−χ²/2) over the prior square to within a factor 1.65 (0.5 in ln Z)."""
    import math

    from diagnostics.hypotheses import PARAMETERS
    from diagnostics.measurement import MeasurementRecord, OperatingCondition
    from diagnostics.observations import observe
    from diagnostics.ranking import Ranker
    from sim.errors import SimulationError

    rig = reference_rig()
    cond = OperatingCondition.from_readings({"oil_temperature": 45.72, "load_force": 2751.5})
    rec = MeasurementRecord.from_readings("ridge", cond, {"velocity_ratio": 0.7827})
    ranker = Ranker(rig, [observe(rec, rig)], 0.002)
    fit = next(f for f in ranker.rank() if f.name == "cylinder+valve")
    m = ranker.models[0]
    ps = (PARAMETERS["cc"], PARAMETERS["cv"])
    n = 41
    axes = [np.linspace(p.to_z(p.worn_bounds(rig)[0]), p.to_z(p.worn_bounds(rig)[1]), n)
            for p in ps]
    logl = np.full((n, n), -np.inf)
    for i, a in enumerate(axes[0]):
        for j, b in enumerate(axes[1]):
            try:
                pred = m.maps.predict(ps, np.array([ps[0].from_z(a), ps[1].from_z(b)]))
            except SimulationError:
                continue
            logl[i, j] = -0.5 * float(m.chi2_grid(pred[None, :])[0])
    top = float(logl.max())
    wt = np.ones(n)
    wt[[0, -1]] = 0.5
    exact = top + math.log(float(wt @ np.exp(logl - top) @ wt) / (n - 1) ** 2)
    assert abs(fit.log_evidence - exact) < 0.5, (fit.log_evidence, exact)


@pytest.mark.parametrize(("theta", "says"), [
    (-10.0, ("outside 20-80 °C", "is extrapolated there")),
    (95.0, ("outside 20-80 °C",)),  # inside the oil's reference points: no extrapolation
    (40.0, ()),
])
def test_an_oil_temperature_beyond_the_checked_range_is_noted(
        rig, theta: float, says: tuple[str, ...]) -> None:
    rec = record(rig, {}, temperature=theta)
    notes = " ".join(diagnose(rig, [rec]).notes)
    assert all(s in notes for s in says)
    assert bool(says) == ("outside" in notes)
    assert ("extrapolated" in notes) == (len(says) == 2)


def test_a_fit_on_the_worn_edge_is_mild_whatever_the_round_off():
    """Each worn range starts on the ``mild`` edge (leakage × 1.33, a setting 5 % down):
    a spool there read 1.3299999999999983 and ``none`` beside a seal at 1.3300000000000032
    and ``mild``, so "seal and spool wear" said the spool was not worn (a user pass)."""
    from diagnostics.hypotheses import PARAMETERS
    from diagnostics.ranking import severity

    rig = reference_rig()
    for name in ("cc", "cv", "pump_leak", "seat_leak", "Pset"):
        p = PARAMETERS[name]
        lo, hi = p.worn_bounds(rig)
        edge = hi if name == "Pset" else lo
        nominal = p.nominal_value(rig)
        for x in (edge * (1 - 1e-15), edge, edge * (1 + 1e-15)):
            assert severity(p, x, nominal)[1] == "mild", (name, x)
        assert severity(p, nominal, nominal)[1] == "none"
    assert severity(PARAMETERS["cv"], 34e-6 * 1.05, 34e-6)[1] == "none"   # 1.158×: none


def test_a_stroke_far_slower_than_the_pump_drives_is_noted():
    """A healthy record with duration_work typed in ms (3230 for 3.23 s) was answered
    "cylinder+valve, p = 1.00, severe" without a word (a user pass): a phase ≥ 30× slower
    than ω·Vp/A is possible (a nearly stalled piston) and is said, naming the ms reading;
    the same record in s says nothing of it."""
    from diagnostics.consistency import slow_stroke_notes
    from diagnostics.observations import rig_limits

    rig = reference_rig()
    limits = rig_limits(rig)
    bound = limits.Vp * limits.speed / limits.A1          # 0.2201 m/s on the preset
    cond = OperatingCondition.from_readings({"oil_temperature": 45.0, "load_force": 4200.0})
    base = {"pump_pressure": 24.4e5, "p1": 21.8e5, "p2": 1.2e5}
    typed = MeasurementRecord.from_readings("rig-1", cond, {**base, "duration_work": 3230.0})
    (note,) = slow_stroke_notes(typed, limits)
    assert "duration_work = 3230 s: if that was in ms, 3.23 s" in note
    assert f"{bound * 3230.0 / 0.5:.0f}× below" in note
    right = MeasurementRecord.from_readings("rig-1", cond, {**base, "duration_work": 3.23})
    assert slow_stroke_notes(right, limits) == []
    assert any("if that was in ms" in n for n in diagnose(rig, [typed]).notes)
    # a stated speed that slow is noted without the ms guess
    (creep,) = slow_stroke_notes(MeasurementRecord.from_readings(
        "rig-1", cond, {**base, "speed_work": 1e-3}), limits)
    assert "if that was in ms" not in creep and "nearly stalled" in creep
