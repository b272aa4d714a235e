"""The range test (a fit pinned on a prior bound), beyond-range explanations, and the
honest degrees of freedom of the goodness-of-fit test (issue 11)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2 as chi2_dist

from diagnostics.diagnose import diagnose
from diagnostics.fastpath.maps import FastMaps
from diagnostics.goodness import TEST_LEVEL, goodness_of_fit
from diagnostics.hypotheses import PARAMETERS
from diagnostics.observations import observe
from diagnostics.range_test import _bounds, _chi2, chi2_points, pinned, range_test, range_tests
from diagnostics.ranking import Ranker
from sim.rigs import reference_rig
from tests.diagnostics.synth import FULL, NO_FLOW, RATIO, readings, record


@pytest.fixture(scope="module")
def rig():
    return reference_rig()


def _ranked(rig, rec):
    ranker = Ranker(rig, [observe(rec, rig)])
    return ranker, ranker.rank()


def test_a_pump_leak_beyond_its_prior_is_found_past_the_bound(rig):
    """Pump leakage 40 × nominal (prior 1.33-20): the pump fit sits on its severe bound;
    the range test rejects the range and finds the leak factor past it, at the truth
    (noise-free readings: to the solver's accuracy, well inside 2 %)."""
    rec = record(rig, {"pump.Rlp": rig.base["pump.Rlp"] / 40.0}, load=2100.0)
    ranker, fits = _ranked(rig, rec)
    pump = next(f for f in fits if f.name == "pump")
    assert pinned(ranker, pump) == [(0, "severe")]
    rt = range_test(ranker, pump, TEST_LEVEL)
    assert rt is not None and rt.rejected
    assert rt.limit == pytest.approx(chi2_dist.ppf(1 - TEST_LEVEL, 1))
    assert rt.statistic == pytest.approx(rt.chi2_bounded - rt.chi2_extended)
    assert rt.extended["pump_leak"] == pytest.approx(40.0, rel=0.02)
    assert rt.chi2_extended < 1.0  # noise-free: the extended fit is exact


def test_a_fault_inside_its_prior_passes_the_range_test(rig):
    """Pump leakage 15 × nominal (inside the prior) with instrument noise: explained, a
    confident name, no beyond-range explanation."""
    rng = np.random.default_rng(5)
    rec = record(rig, {"pump.Rlp": rig.base["pump.Rlp"] / 15.0}, load=2100.0, rng=rng)
    d = diagnose(rig, [rec])
    assert d.explained and d.confident and d.fit is not None
    assert d.fit.beyond_range == []
    assert not any(t.rejected for t in d.fit.range_tests)


def test_a_held_relief_setting_below_its_prior_is_stated_as_an_alternative(rig):
    """Relief set at 0.2 × nominal (prior 0.3-0.95), 6.3 kN: the piston is held on its stop
    and without flow meters its pressures read as a worn spool as well; the result must
    say that a relief setting beyond the prior explains them, at the true setting, and
    not give a confident name."""
    pset = 0.2 * rig.base["relief.Pset"]
    vals = readings(rig, {"relief.Pset": pset}, 6300.0, 40.0)
    assert vals["speed_work"] == 0.0  # held on its end stop
    rec = record(rig, {}, load=6300.0, values=vals, fields=("pump_pressure", "p1", "p2"))
    d = diagnose(rig, [rec])
    assert d.fit is not None and not d.confident
    assert d.explained  # in-library pairs fit the held pressures too (spool and pump wear)
    (alt,) = [t for t in d.fit.beyond_range if t.hypothesis == "relief_setting"]
    assert alt.extended["Pset"] == pytest.approx(pset, rel=0.01)
    assert alt.chi2_extended <= chi2_dist.ppf(1 - TEST_LEVEL, 2)
    assert "beyond the library's prior range" in d.fit.statement
    assert "relief" in d.fit.statement.split("check")[-1]
    assert d.to_dict()["confident"] is False


def test_a_relief_setting_that_no_prior_value_opens_is_still_found_below_the_prior(rig):
    """Relief at 0.19 × nominal at 2.1 kN, where the healthy pump pressure (14.6 bar)
    lies below the prior's lowest setting (0.3 × 70 bar): no setting in the prior opens,
    so relief_setting is unobservable, yet the readings are the relief's; they were
    "unexplained" with nothing beyond range and "relief_setting: not observable" quoting
    the model's pressure as the pump's (an engineer's pass).  Full sensors, noise-free."""
    pset = 0.19 * rig.base["relief.Pset"]
    rec = record(rig, {"relief.Pset": pset}, load=2100.0)
    d = diagnose(rig, [rec])
    assert d.fit is not None and not d.confident
    (alt,) = [t for t in d.fit.beyond_range if t.hypothesis == "relief_setting"]
    assert alt.extended["Pset"] == pytest.approx(pset, rel=0.01)
    # the best setting in bar, as an engineer reads it ("best 1.112e+06": an operator)
    assert f"(best {alt.extended['Pset'] / 1e5:.4g} bar)" in alt.describe()
    assert "check relief directly" in d.fit.statement
    relief = next(s for s in d.isolability.statements if s.startswith("relief_setting"))
    assert "model's pump pressure" in relief and "measured" in relief


def test_ratio_alone_states_that_a_misfit_cannot_be_detected(rig):
    """One reading and one-parameter hypotheses: no degree of freedom is left, so a
    passing single fault is no χ² test; the result says so (dof 0, testable false)."""
    vals = readings(rig, {"valve.cv": 50e-6}, 2100.0, 40.0)
    d = diagnose(rig, [record(rig, {}, values=vals, fields=RATIO)])
    assert d.fit is not None and d.explained
    assert len(d.top.hypothesis.parameters) >= 1
    assert not d.fit.testable and not d.confident
    assert d.fit.dof == 0 and d.fit.limit == float("inf") and d.fit.p_value == 1.0
    assert "cannot be detected" in d.fit.statement
    body = d.to_dict()["goodness_of_fit"]
    assert body["testable"] is False and body["dof"] == 0


def test_dof_counts_every_parameter(rig):
    """ν = n − k without a floor: the full set (7 readings) and a pair leave 5."""
    rng = np.random.default_rng(2)
    rec = record(rig, {"valve.cv": 50e-6, "pump.Rlp": rig.base["pump.Rlp"] / 6.0},
                 load=2100.0, rng=rng, fields=FULL)
    ranker, fits = _ranked(rig, rec)
    gof = goodness_of_fit(ranker, fits)
    tested = next(f for f in fits if f.name == gof.hypothesis)
    assert gof.dof == len(FULL) - len(tested.hypothesis.parameters)
    assert gof.testable


def test_extended_ranges_contain_the_priors(rig):
    for p in PARAMETERS.values():
        lo, hi = p.worn_bounds(rig)
        elo, ehi = p.extended_bounds(rig)
        assert elo < lo and ehi >= hi


def test_no_flow_meters_in_library_is_explained(rig):
    """A worn spool (cv 50 µm), moving piston, no flow meters, with noise: explained."""
    rng = np.random.default_rng(9)
    d = diagnose(rig, [record(rig, {"valve.cv": 50e-6}, load=2100.0, rng=rng,
                              fields=NO_FLOW)])
    assert d.explained and d.fit is not None and d.fit.testable


def test_ratio_alone_out_of_every_hypothesis_reach_is_not_explained(rig):
    """A velocity ratio 20 % above the healthy one: wear only lowers it on this rig, so no
    hypothesis reaches it — with one reading this is still a misfit, detected (the best
    fit's χ² is at most a χ²_n variable at the truth: χ²_{1-α}(n) keeps the level)."""
    vals = readings(rig, {}, 2100.0, 40.0)
    d = diagnose(rig, [record(rig, {}, values={"velocity_ratio": 1.2 * vals["velocity_ratio"]},
                              fields=RATIO)])
    assert d.fit is not None and not d.explained and d.fit.testable
    assert all(f.chi2 > chi2_dist.ppf(1 - TEST_LEVEL, 1) for f in d.hypotheses if f.observable)
    assert "not explained" in d.fit.statement


def _pinned_singles(ranker, fits):
    return [f for f in fits if len(f.parameters) == 1 and pinned(ranker, f)]


def test_the_compiled_chi2_is_the_direct_chi2(rig):
    """The range test's compiled evaluator (one kernel call for many points) scores
    every point as the direct steady solves do, past the priors too (a held piston and a
    stalled one included: relief settings down to the extended bound)."""
    rng = np.random.default_rng(3)
    rec = record(rig, {"valve.cv": 3.0 * rig.base["valve.cv"]}, load=4200.0, rng=rng)
    ranker, _ = _ranked(rig, rec)
    assert all(isinstance(m.maps, FastMaps) for m in ranker.models)  # the compiled branch
    ps, zs = [], []
    for name in ("pump_leak", "Pset", "cv", "cc"):
        p = PARAMETERS[name]
        _, _, zl, zu = _bounds(ranker, p)
        ps += [p] * 9
        zs += list(np.linspace(zl, zu, 9))
    fast = chi2_points(ranker, ps, np.array(zs))
    direct = np.array([_chi2(ranker, (p,), np.array([z])) for p, z in zip(ps, zs, strict=True)])
    assert np.isfinite(direct).all()
    np.testing.assert_allclose(fast, direct, rtol=1e-7)


def test_tests_run_together_equal_tests_run_alone(rig):
    """:func:`range_tests` searches all pinned singles in one batch; each answer is the
    one its own :func:`range_test` gives."""
    rng = np.random.default_rng(8)
    rec = record(rig, {"pump.Rlp": rig.base["pump.Rlp"] / 40.0}, load=2100.0, rng=rng)
    ranker, fits = _ranked(rig, rec)
    singles = _pinned_singles(ranker, fits)
    assert len(singles) >= 2
    together = range_tests(ranker, singles, TEST_LEVEL)
    for f, t in zip(singles, together, strict=True):
        alone = range_test(ranker, f, TEST_LEVEL)
        assert (t is None) == (alone is None)
        if t is not None and alone is not None:
            assert t.chi2_extended == pytest.approx(alone.chi2_extended, rel=1e-9, abs=1e-9)
            assert t.rejected == alone.rejected


def test_the_search_finds_the_minimum_of_a_dense_scan(rig):
    """The grid-and-refine search beyond the bound reaches the lowest χ² of a 400-point
    direct scan of the extended range (to 1e-3 of it, or 1e-3 absolute)."""
    rng = np.random.default_rng(4)
    rec = record(rig, {"pump.Rlp": rig.base["pump.Rlp"] / 35.0}, load=2100.0, rng=rng)
    ranker, fits = _ranked(rig, rec)
    for f in _pinned_singles(ranker, fits):
        rt = range_test(ranker, f, TEST_LEVEL)
        if rt is None:
            continue
        p = PARAMETERS[f.parameters[0].name]
        zl, zu, zle, zue = _bounds(ranker, p)
        z0 = p.to_z(f.parameters[0].value)
        lo, hi = (zle, zu) if abs(z0 - zl) < abs(z0 - zu) else (zl, zue)
        scan = min(_chi2(ranker, (p,), np.array([z])) for z in np.linspace(lo, hi, 400))
        assert rt.chi2_extended <= min(scan, rt.chi2_bounded) + max(1e-3, 1e-3 * scan)


def test_a_second_record_at_the_same_condition_reuses_the_first_grids(rig, monkeypatch):
    """The first search grids' predictions do not depend on the readings: a second record
    at the condition (other noise) solves none of them again, and its answers are the ones
    it gets with nothing kept (to the solver's continuation, 1e-9)."""
    rec1 = record(rig, {"pump.Rlp": rig.base["pump.Rlp"] / 40.0}, load=2100.0,
                  rng=np.random.default_rng(11))
    rec2 = record(rig, {"pump.Rlp": rig.base["pump.Rlp"] / 40.0}, load=2100.0,
                  rng=np.random.default_rng(12))
    ranker1, fits1 = _ranked(rig, rec1)
    range_tests(ranker1, _pinned_singles(ranker1, fits1), TEST_LEVEL)
    ranker2, fits2 = _ranked(rig, rec2)
    maps = ranker2.models[0].maps
    assert maps is ranker1.models[0].maps and maps.kept  # one condition, one set of maps
    singles = _pinned_singles(ranker2, fits2)
    solved: list[int] = []
    probe = FastMaps.probe_moving

    def counting(self, params, zs, starts, even=False):
        solved.append(sum(z.size for z in zs))
        return probe(self, params, zs, starts, even)

    monkeypatch.setattr(FastMaps, "probe_moving", counting)
    kept = range_tests(ranker2, singles, TEST_LEVEL)
    with_kept = sum(solved)
    maps.kept.clear()
    solved.clear()
    fresh = range_tests(ranker2, singles, TEST_LEVEL)
    grid_points = 24 * sum(1 for t in fresh if t is not None and len(t.parameters) == 1)
    assert sum(solved) - with_kept == grid_points > 0
    for a, b in zip(kept, fresh, strict=True):
        assert (a is None) == (b is None)
        if a is not None and b is not None:
            assert a.chi2_extended == pytest.approx(b.chi2_extended, rel=1e-9, abs=1e-9)
            assert a.rejected == b.rejected


def test_wear_below_the_worn_range_is_incipient_not_better_than_the_document(rig):
    """A piston seal whose leakage is 1.2 × nominal (cc 1.063 × c0): past the document's
    value, short of the worn range (from leakage 1.33 ×).  Noise-free, full sensors: the
    cylinder fit sits on the healthy end of its worn range; tested against the document's
    value the range holds, the readings place cc between the two (at the truth, to the
    solver's accuracy), the readings are explained by the cylinder fit there — incipient,
    not a confident name — where they were once "not explained: cc better than the rig
    document" (found diagnosing a seal that wears week by week)."""
    c0 = rig.base["cylinder.cc"]
    truth = c0 * 1.2 ** (1 / 3)
    rec = record(rig, {"cylinder.cc": truth}, load=4200.0, temperature=45.0)
    ranker, fits = _ranked(rig, rec)
    cyl = next(f for f in fits if f.name == "cylinder")
    assert pinned(ranker, cyl) == [(0, "healthy")]
    rt = range_test(ranker, cyl, TEST_LEVEL)
    assert rt is not None and not rt.rejected and rt.sides == ["incipient"]
    assert rt.statistic > rt.limit  # the worn range's start alone is rejected
    assert rt.incipient["cc"] == pytest.approx(truth, rel=2e-3)
    assert rt.chi2_document < 1e-2  # noise-free: exact there
    d = diagnose(rig, [rec])
    # the probabilities rank the worn hypotheses (the gap has no prior mass): the
    # explaining fit is named by the goodness-of-fit test and its statement
    assert d.explained and d.fit is not None and d.fit.hypothesis == "cylinder"
    assert not d.fit.confident and d.fit.incipient is not None
    assert "incipient wear of the cylinder" in d.fit.statement
    assert "better than the rig document" not in d.fit.statement


def test_a_joint_visit_at_incipient_wear_is_explained_by_the_second_pass(rig):
    """Three records (2.1 / 4.2 / 6.3 kN) of the same seal at leakage 1.2 × nominal, with
    instrument noise: at the start of the worn range the cylinder fit fails the χ² test
    outright, so only the second pass (fits on the healthy end of their worn range,
    tested at the values their range test finds) explains them — as incipient cylinder
    wear, with the χ² taken there."""
    rng = np.random.default_rng(21)
    truth = rig.base["cylinder.cc"] * 1.2 ** (1 / 3)
    recs = [record(rig, {"cylinder.cc": truth}, load=load, temperature=t, rng=rng)
            for load, t in ((2100.0, 35.0), (4200.0, 45.0), (6300.0, 50.0))]
    d = diagnose(rig, recs)
    cyl = next(f for f in d.hypotheses if f.name == "cylinder")
    assert d.fit is not None and d.fit.incipient is not None
    assert cyl.chi2 > d.fit.limit  # at the bound: fails
    assert d.explained and d.fit.hypothesis == "cylinder" and d.fit.chi2 <= d.fit.limit
    assert d.fit.incipient.incipient["cc"] == pytest.approx(truth, rel=0.02)


def test_a_component_better_than_its_document_is_still_not_explained(rig):
    """A piston seal tighter than the document says (cc 0.8 × c0: a rig document whose
    clearance is off), noise-free: below the document's value the range test still
    rejects the cylinder ('better than the rig document'), and nothing else explains
    the readings."""
    rec = record(rig, {"cylinder.cc": 0.8 * rig.base["cylinder.cc"]}, load=4200.0)
    ranker, fits = _ranked(rig, rec)
    cyl = next(f for f in fits if f.name == "cylinder")
    rt = range_test(ranker, cyl, TEST_LEVEL)
    assert rt is not None and rt.rejected and rt.sides == ["healthy"]
    assert rt.extended["cc"] == pytest.approx(0.8 * rig.base["cylinder.cc"], rel=2e-3)
    assert rt.chi2_document - rt.chi2_extended > rt.limit


def test_a_component_at_its_document_value_is_not_worn(rig):
    """Noise-free healthy readings: a cylinder fit pinned on the healthy end of its worn
    range finds the document's value beyond it — the cylinder is as built, the
    hypothesis that blames it is rejected ('document'), not called incipient."""
    rec = record(rig, {}, load=4200.0)
    ranker, fits = _ranked(rig, rec)
    cyl = next(f for f in fits if f.name == "cylinder")
    rt = range_test(ranker, cyl, TEST_LEVEL)
    assert rt is not None and rt.rejected and rt.sides == ["document"]
    assert rt.incipient == {}
    assert "at the rig document's value" in rt.describe()
