"""'None of these fits' is an answer: the χ² goodness-of-fit test of the best hypothesis."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2 as chi2_dist

from diagnostics.diagnose import diagnose
from diagnostics.goodness import TEST_LEVEL
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.quantity import DEFAULT_INSTRUMENTS, Quantity
from sim.rigs import load_rig, reference_rig, reference_rig_document
from tests.diagnostics.synth import FULL, NO_FLOW, readings, record


@pytest.fixture(scope="module")
def rig():
    return reference_rig()


def test_in_library_faults_with_noise_are_explained(rig):
    rng = np.random.default_rng(11)
    cases = [{}, {"cylinder.cc": 110e-6}, {"valve.cv": 50e-6}, {"pump.Rlp": 6e11 / 4},
             {"relief.Gseat": 3.0 / 6e11}]
    for ov in cases:
        d = diagnose(rig, [record(rig, ov, load=4200.0, temperature=45.0, rng=rng)])
        assert d.explained, (ov, d.fit)
        assert d.fit is not None and d.fit.chi2 <= d.fit.limit
        # the limit is the χ² quantile of the stated level
        assert d.fit.limit == pytest.approx(chi2_dist.ppf(1 - TEST_LEVEL, d.fit.dof))
        assert d.to_dict()["misfit"] is None


def test_a_biased_sensor_is_not_explained_and_named_with_its_sigma(rig):
    vals = readings(rig, {"valve.cv": 45e-6}, 2100.0, 40.0)
    biased = dict(vals, p1=vals["p1"] * 1.05)  # 5 % on a 0.25 % class gauge
    d = diagnose(rig, [record(rig, {}, values=biased)])
    assert not d.explained
    # the name to act on says so, whatever the most probable hypothesis is (top.name read
    # "healthy" p 1.0 for pressures in bar typed as Pa: a library user's pass)
    assert d.answer == "unexplained" == d.to_dict()["top"] and d.top.name != "unexplained"
    assert d.isolability.ambiguity_set == []
    assert d.fit is not None
    worst = d.fit.disagreements[0]
    assert worst.reading == "p1" and abs(worst.deviation) > 5.0
    assert d.fit.chi2 > d.fit.limit
    text = d.to_dict()["misfit"]
    assert "not explained by the rig model" in text and "p1" in text
    assert "hydrodiag discover" in text and "commission" in text


def test_readings_of_another_rig_are_not_explained(rig):
    """A mis-specified model: the readings come from a rig whose valve passes a quarter of
    the flow coefficient the document states (not a fault in the library)."""
    doc = reference_rig_document()
    doc["name"] = "narrow-valve"
    doc["components"]["valve"]["parameters"]["K"]["value"] = 0.2e-6
    other = load_rig(doc)
    vals = readings(other, {}, 4200.0, 40.0)
    d = diagnose(rig, [record(rig, {}, load=4200.0, values=vals)])
    assert not d.explained
    assert d.top.probability <= 1.0
    assert d.to_dict()["explained"] is False


def test_a_relief_setting_at_0_38_of_nominal_is_inside_the_prior_and_found(rig):
    """Issue 11's relief case: 0.38 × nominal was outside the old 0.5-1.0 prior."""
    pset = 0.38 * rig.base["relief.Pset"]
    d = diagnose(rig, [record(rig, {"relief.Pset": pset}, load=6300.0, temperature=40.0,
                              fields=(*FULL, "pump_flow"))])
    assert d.explained
    assert d.top.name == "relief_setting"
    (est,) = d.top.parameters
    assert est.low <= pset <= est.high


def test_a_moving_piston_is_not_called_stalled(rig):
    vals = readings(rig, {"valve.cv": 45e-6}, 2100.0, 40.0)
    d = diagnose(rig, [record(rig, {}, values=dict(vals, p1=vals["p1"] * 1.05))])
    assert not d.explained and "Model limit" not in d.to_dict()["misfit"]


@pytest.mark.parametrize(("leak", "offsets"), [(6.0, (-0.9, 0.9, -0.9)),
                                               (9.0, (0.9, -0.9, 0.9))])
def test_a_worn_seals_visit_with_temperatures_stated_within_class_is_explained(
        leak: float, offsets: tuple[float, float, float]) -> None:
    """A seal at 6 or 9 × its leakage, one visit at 2.1/4.2/6.3 kN without flow meters,
    noise-free readings, each record's oil temperature stated 0.9 K off (inside the
    thermometer's ±1 K class, alternating in sign): the worn seal's leakage makes the
    readings feel the temperature far more than the healthy rig's, whose sensitivity the
    ranking's covariance carries — the visit was "not explained" (χ² 113 and 174 on 14
    degrees of freedom). With the sensitivity taken at the fitted wear the χ² test passes
    and says so."""
    rig = reference_rig()
    cc = 83e-6 * leak ** (1 / 3)
    records = []
    for load, off in zip((2100.0, 4200.0, 6300.0), offsets, strict=True):
        v = readings(rig, {"cylinder.cc": cc}, load, 40.0)
        cond = OperatingCondition.from_readings({"oil_temperature": 40.0 + off,
                                                 "load_force": load})
        records.append(MeasurementRecord.from_readings("r", cond, {f: v[f] for f in NO_FLOW}))
    d = diagnose(rig, records)
    assert d.explained and d.fit is not None
    assert d.fit.chi2 <= d.fit.limit
    assert "taken at the fitted wear" in d.fit.statement
    assert "cylinder" in d.isolability.ambiguity_set
    (est,) = next(f for f in d.hypotheses if f.name == "cylinder").parameters
    assert est.low <= cc <= est.high
    # the readings it names are in the σ the test weighed them by (at the fitted wear:
    # the healthy rig's σ put the working speed 6-9 σ off in a χ² that passes)
    if d.fit.hypothesis == "cylinder":
        assert all(abs(x.deviation) < 4.0 for x in d.fit.disagreements)


def test_the_statement_says_how_the_most_probable_fit_fares_when_it_names_another() -> None:
    """The test names the fit with the best p-value, which the answer's most probable
    hypothesis need not be (a simpler fault, a higher prior): the statement then says
    whether that one passes the same test, with its own χ² and limit (random faulty and
    healthy records of every sensor subset)."""
    from benchmarks.diagnose_cases import SUBSETS, random_record
    from diagnostics.goodness import chi2_limit

    rig = reference_rig()
    rng = np.random.default_rng(21)
    seen = 0
    while seen < 6:
        rec = random_record(rng, rig, SUBSETS)
        if rec is None:
            continue
        d = diagnose(rig, [rec])
        assert d.fit is not None
        if not (d.explained and d.fit.testable) or d.fit.hypothesis == d.top.name:
            assert "the most probable" not in d.fit.statement
            continue
        seen += 1
        top = d.top
        dof = d.n_observations - len(top.hypothesis.parameters)
        clause = d.fit.statement.split(f"; the most probable, {top.name}, ")[1]
        if dof < 1:
            assert clause.startswith("has as many parameters as readings")
            continue
        limit = chi2_limit(TEST_LEVEL, dof)
        # a single fault is tested again with the stated condition at its estimate
        retest = top.chi2_at_estimate if len(top.hypothesis.parameters) == 1 else np.nan
        chi2 = min(top.chi2, retest) if np.isfinite(retest) else top.chi2
        assert clause.startswith("passes it too" if chi2 <= limit else "does not pass it")
        assert f"on {dof} degrees of freedom, limit {limit:.3g})" in clause


def test_isolated_is_a_confident_name_that_holds_the_probability_alone(rig):
    """`confident` is not certainty: a worn spool read by the three pressures alone was
    `pump` p = 0.30, confident (an engineer's pass); `isolated` says whether the name can be
    acted on alone."""
    spool = {"valve.cv": 59e-6}
    pressures = diagnose(rig, [record(rig, spool, load=4200.0, temperature=45.0,
                                      fields=("pump_pressure", "p1", "p2"))])
    out = pressures.to_dict()
    assert out["confident"] is True and out["isolated"] is False
    assert pressures.top.probability < 0.95 and len(pressures.isolability.credible_set) > 1
    full = diagnose(rig, [record(rig, spool, load=4200.0, temperature=45.0)])
    out = full.to_dict()
    assert out["top"] == "valve" and out["isolated"] is True
    # the nested pair shares the probability; the valve is in both
    assert set(full.isolability.credible_set) == {"valve", "valve+pump"}


def test_readings_that_can_see_no_fault_are_not_a_confident_healthy(rig):
    """Huge stated uncertainties, or one weak reading, left every fault below one σ of
    effect, out of the probabilities, and healthy alone came back p = 1.000, confident,
    isolated (an edge pass): it is neither, and a note says nothing was seen."""
    from diagnostics.diagnose import BLIND_NOTE
    from diagnostics.quantity import Quantity

    vals = readings(rig, {}, 2100.0, 40.0)
    cond = OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": 2100.0})
    for k in (10.0, 1e6):
        vague = MeasurementRecord.from_readings(
            "rig-1", cond, {f: Quantity(vals[f], k * abs(vals[f])) for f in FULL})
        d = diagnose(rig, [vague])
        out = d.to_dict()
        assert d.blind and out["top"] == "healthy"
        assert out["confident"] is False and out["isolated"] is False
        assert BLIND_NOTE in d.notes
    # sharp readings of the same rig see the faults: no such note
    sharp = diagnose(rig, [record(rig, {}, values=vals)])
    assert not sharp.blind and BLIND_NOTE not in sharp.notes


def test_an_oil_temperature_stated_in_fahrenheit_is_named_among_the_causes(rig):
    """Readings taken at 20 °C stated as 68 (°F): not explained, and the stated condition,
    the likeliest cause in a fleet's data, was not among the causes named (a fleet
    integrator's pass)."""
    vals = readings(rig, {}, 2100.0, 20.0)
    d = diagnose(rig, [record(rig, {}, temperature=68.0, values=vals)])
    assert not d.explained
    text = d.to_dict()["misfit"]
    assert "a stated condition that is wrong (an oil temperature in °F" in text


@pytest.mark.parametrize("model_rel", [-1.0, float("inf"), 5.0, float("nan"), False, "0.02"])
def test_a_model_error_that_means_nothing_is_refused(rig, model_rel: float) -> None:
    """−1, inf or 5 turned a worn spool into "healthy" (a library user's pass); a bool or
    a string is no number (False was taken: a verification pass)."""
    from sim.errors import ParameterError

    with pytest.raises(ParameterError) as caught:
        diagnose(rig, [record(rig, {"valve.cv": 59e-6})], model_rel=model_rel)
    assert caught.value.field == "model_rel"


def test_a_model_error_given_as_a_numpy_number_is_taken(rig) -> None:
    """``np.float32(0.02)`` was refused where every other argument takes numpy numbers."""
    import numpy as np

    worn = [record(rig, {"valve.cv": 59e-6})]
    assert diagnose(rig, worn, model_rel=np.float32(0.02)).answer == \
        diagnose(rig, worn, model_rel=0.02).answer


def test_the_readmes_python_example_answers_valve(rig):
    """The README's record of a worn spool, diagnosed as its Python example does."""
    cond = OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": 2100.0})
    rec = MeasurementRecord.from_readings("rig-1", cond, {
        "pump_pressure": 14.50e5, "p1": 11.88e5, "p2": 1.202e5, "flow_B": 4.643e-4,
        "flow_C": 4.172e-4, "speed_work": 0.1881, "speed_return": 0.2177})
    d = diagnose(rig, [rec])
    assert d.answer == "valve" == d.top.name
    (cv,) = d.top.parameters
    assert cv.value == pytest.approx(60e-6, rel=0.05)


def test_a_worn_seal_in_cold_oil_is_stored_at_its_worn_root(rig):
    """In cold oil two seal clearances give one bypass; the root nearer the rig's read a
    200 µm seal at −20 °C as 75.8 µm while the diagnosis named the cylinder (a
    verification pass).  A healthy seal keeps its own root; both intervals hold both."""
    worn = diagnose(rig, [record(rig, {"cylinder.cc": 200e-6}, load=2100.0,
                                 temperature=-20.0)])
    assert "cylinder" in worn.answer
    cc = worn.direct["cc"]
    assert cc.value == pytest.approx(200e-6, rel=1e-3)
    assert cc.low < cc.derived["other_root"] < cc.value <= cc.high
    healthy = diagnose(rig, [record(rig, {}, load=2100.0, temperature=-30.0)])
    assert healthy.answer == "healthy"
    assert healthy.direct["cc"].value == pytest.approx(83e-6, rel=1e-3)


def _alternating(rig, scale: float, *, shift: float = 2.4) -> MeasurementRecord:
    """A worn spool's full readings each moved by ``shift`` of its class σ, alternately
    up and down, every uncertainty (readings, stated load and temperature) ``scale`` × its
    class σ."""
    vals = readings(rig, {"valve.cv": 45e-6}, 4200.0, 45.0)
    out = {}
    for j, f in enumerate(FULL):
        inst = DEFAULT_INSTRUMENTS[f]
        u = (inst.relative_bound * abs(vals[f]) + inst.absolute_bound) / np.sqrt(3.0)
        out[f] = Quantity(vals[f] + shift * u * (-1) ** j, scale * u)
    ut = DEFAULT_INSTRUMENTS["condition.oil_temperature"].absolute_bound / np.sqrt(3.0)
    ul = DEFAULT_INSTRUMENTS["condition.load_force"].relative_bound * 4200.0 / np.sqrt(3.0)
    cond = OperatingCondition.from_readings({"oil_temperature": Quantity(45.0, scale * ut),
                                             "load_force": Quantity(4200.0, scale * ul)})
    return MeasurementRecord.from_readings("rig-1", cond, out)


def test_the_uncertainty_factor_is_where_the_best_fit_would_pass(rig):
    """Readings 2.4 σ off in alternating signs: no fault explains them at their stated
    uncertainties.  The result's factor s = √(χ²/limit) is the common factor on every
    uncertainty at which the same fit passes: scaling the whole covariance by c² divides χ²
    by c² and leaves the estimate, so s·c and χ²·c² stay put, the readings are explained
    just above s and not just below it, and the statement gives s."""
    d = diagnose(rig, [_alternating(rig, 1.0)])
    assert not d.explained and d.fit is not None
    s = d.fit.uncertainty_factor
    assert s == pytest.approx(np.sqrt(d.fit.chi2 / d.fit.limit), rel=1e-12)
    assert 1.0 < s < 1.5
    assert f"were every uncertainty {s:.2f}× the stated one" in d.to_dict()["misfit"]
    for c, explained in ((0.98 * s, False), (1.02 * s, True)):
        again = diagnose(rig, [_alternating(rig, c)], model_rel=0.002 * c)
        assert again.explained is explained
        assert again.fit is not None and again.fit.hypothesis == d.fit.hypothesis
        assert again.fit.chi2 * c * c == pytest.approx(d.fit.chi2, rel=1e-6)
        assert again.fit.uncertainty_factor * c == pytest.approx(s, rel=1e-6)
        for e, e0 in zip(again.top.parameters, d.top.parameters, strict=True):
            assert e.value == pytest.approx(e0.value, rel=1e-6)


def test_an_explained_fit_states_its_margin_and_a_far_misfit_a_large_factor(rig):
    ok = diagnose(rig, [record(rig, {"valve.cv": 45e-6}, load=4200.0, temperature=45.0)])
    assert ok.explained and ok.fit is not None
    assert 0.0 <= ok.fit.uncertainty_factor <= 1.0
    assert "stated uncertainties" not in ok.fit.statement
    vals = readings(rig, {"valve.cv": 45e-6}, 2100.0, 40.0)
    far = diagnose(rig, [record(rig, {}, values=dict(vals, p1=vals["p1"] * 1.05))])
    assert far.fit is not None and far.fit.uncertainty_factor > 3.0
    # beyond 3 no instrument's noise: the statement does not offer it as a cause
    assert "scatter more than their stated" not in far.to_dict()["misfit"]
