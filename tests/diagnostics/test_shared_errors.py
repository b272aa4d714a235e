"""Instrument errors shared by a joint visit's records (diagnostics/shared_errors.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from diagnostics.commissioning import commission
from diagnostics.condition_interval import check_singles, estimate_parts
from diagnostics.diagnose import diagnose
from diagnostics.evidence_at_fit import evidence_at_fit
from diagnostics.hypotheses import PARAMETERS
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.observations import observe
from diagnostics.ranking import Ranker
from diagnostics.record_model import condition_kinds
from diagnostics.shared_errors import shared_spread, visit_covariance
from sim.errors import MeasurementError
from sim.rigs import reference_rig
from tests.diagnostics.synth import FULL, NO_FLOW, readings, record

#: a worn seal, 2 × the reference clearance [m]
WORN = {"cylinder.cc": 2.0 * 83e-6}
#: a model uncertainty small enough that the readings' own errors are the whole story [-]
TINY = 1e-9


@pytest.fixture(scope="module")
def rig():
    return reference_rig()


def _sigmas(rig, records):
    ranker = Ranker(rig, [observe(r, rig) for r in records], TINY)
    fits = ranker.rank()
    checks = check_singles(ranker, fits)
    pairs = evidence_at_fit(ranker, fits, checks).pair_sigma
    return checks.sigma, {k: np.asarray(v) for k, v in pairs.items()}


@pytest.mark.parametrize("share", [0.0, 0.5, 1.0])
def test_identical_records_narrow_the_interval_by_how_much_their_errors_are_shared(
        rig, share: float) -> None:
    """K identical records whose errors share f of their variance: the estimator's
    variance is that of one record times (1 + f·(K − 1))/K — 1/K when independent, that of
    one record when every error is shared (K readings of one miscalibrated instrument say
    no more than one) — for the one-parameter fits and for each parameter of the pairs."""
    one = record(rig, WORN, fields=NO_FLOW)
    k = 3
    single, single_pairs = _sigmas(rig, [one])
    visit, visit_pairs = _sigmas(rig, [replace(one, calibration_share=share)] * k)
    factor = math.sqrt((1.0 + share * (k - 1)) / k)
    assert set(visit) == set(single) and len(single) >= 4
    for name, sd in single.items():
        assert visit[name] == pytest.approx(factor * sd, rel=1e-6), name
    assert set(visit_pairs) == set(single_pairs) and single_pairs
    for name, sd in single_pairs.items():
        np.testing.assert_allclose(visit_pairs[name], factor * sd, rtol=1e-6, err_msg=name)


def test_the_cross_record_blocks_are_those_of_the_visits_whole_covariance(rig) -> None:
    """Three records at other loads and temperatures, one without flow meters and one
    with half its variance shared: the blocks :func:`shared_spread` adds equal
    ``Σ_{k≠k'} G_kᵀ C_kk' G_k'`` with ``C_kk'`` written out element by element from the
    module docstring's error model (readings by quantity, the thermometer, the load
    cell)."""
    recs = [replace(record(rig, WORN, load=2100.0, temperature=35.0, fields=FULL),
                    calibration_share=1.0),
            replace(record(rig, WORN, load=4200.0, temperature=40.0, fields=NO_FLOW),
                    calibration_share=0.5),
            replace(record(rig, WORN, load=6300.0, temperature=45.0, fields=FULL),
                    calibration_share=1.0)]
    ranker = Ranker(rig, [observe(r, rig) for r in recs])
    p = PARAMETERS["cc"]
    zs = np.array([p.to_z(2.0 * 83e-6)])
    parts = estimate_parts(ranker, [p], zs)
    rng = np.random.default_rng(3)
    weights = [rng.normal(size=(1, m.idx.size, 1)) for m in ranker.models]
    terms = [t for _, _, t in parts]
    got = shared_spread(ranker.models, weights, terms)
    assert got is not None
    expected = 0.0
    for a, (ma, ta) in enumerate(zip(ranker.models, terms, strict=True)):
        for b, (mb, tb) in enumerate(zip(ranker.models, terms, strict=True)):
            if a == b:
                continue
            f = math.sqrt(ma.obs.record.calibration_share * mb.obs.record.calibration_share)
            cov = np.zeros((ma.idx.size, mb.idx.size))
            for i, ni in enumerate(ma.obs.names):
                for j, nj in enumerate(mb.obs.names):
                    if ni == nj:
                        cov[i, j] = f * ma.obs.u[i] * mb.obs.u[j]
            kinds_b = condition_kinds(mb.obs)
            for kind, t in zip(condition_kinds(ma.obs), ta, strict=True):
                if kind in kinds_b:
                    cov += f * np.outer(t[0], tb[kinds_b.index(kind)][0])
            expected += float(weights[a][0, :, 0] @ cov @ weights[b][0, :, 0])
    assert got[0, 0, 0] == pytest.approx(expected, rel=1e-12)
    assert set(condition_kinds(ranker.models[0].obs)) == {"oil_temperature", "load"}


def test_one_record_or_records_that_share_nothing_are_as_before(rig) -> None:
    """A single record's diagnosis is the same whatever its share (one record has no other
    to share an error with), and a visit whose records share nothing states what it did
    before the share existed (None: nothing added)."""
    one = record(rig, WORN, fields=NO_FLOW)
    a = diagnose(rig, [one]).to_dict()
    b = diagnose(rig, [replace(one, calibration_share=1.0)]).to_dict()
    said = [n for n in b["notes"] if n not in a["notes"]]
    assert said == ["calibration_share counts between the records of a joint diagnosis that "
                    "state it (an instrument error they share); one record has no other to "
                    "share it with: nothing changed"]
    assert {**a, "notes": []} == {**b, "notes": []}
    visit = diagnose(rig, [replace(one, calibration_share=1.0), replace(
        record(rig, WORN, fields=NO_FLOW, load=4200.0), calibration_share=0.5)])
    assert [n for n in visit.notes if n.startswith("the intervals count")] == [
        "the intervals count the instruments' errors the records share (calibration_share "
        "1, 0.5); the probabilities take the records as independent"]
    ranker = Ranker(rig, [observe(replace(one, calibration_share=s), rig)
                          for s in (1.0, 0.0, 0.0)])
    weights = [np.ones((1, m.idx.size, 1)) for m in ranker.models]
    assert shared_spread(ranker.models, weights, [[] for _ in ranker.models]) is None


@pytest.mark.parametrize("share", [-0.01, 1.01, math.nan, True, "1"])
def test_a_share_outside_zero_to_one_is_refused_naming_it(rig, share: object) -> None:
    with pytest.raises(MeasurementError) as err:
        MeasurementRecord.from_readings("r", record(rig, WORN).condition, {"p1": 12e5},
                                        calibration_share=share)  # type: ignore[arg-type]
    assert err.value.field == "calibration_share"
    assert "from 0 to 1" in err.value.message


def test_the_visits_stacked_covariance_is_the_error_models(rig) -> None:
    """:func:`visit_covariance` written as ``diag + Σ t tᵀ`` equals the covariance of the
    module docstring's error model element by element: each record's own block unchanged
    (its readings' and conditions' variances whatever the share), the cross-record blocks
    ``√(f_k f_k')·u·u`` between readings of one quantity and ``√(f_k f_k')·t·t'`` between
    the terms of one stated condition."""
    recs = [replace(record(rig, WORN, load=2100.0, temperature=35.0, fields=FULL),
                    calibration_share=1.0),
            replace(record(rig, WORN, load=4200.0, temperature=40.0, fields=NO_FLOW),
                    calibration_share=0.3),
            replace(record(rig, WORN, load=6300.0, temperature=45.0, fields=FULL),
                    calibration_share=0.0),
            replace(record(rig, WORN, load=5000.0, temperature=50.0, fields=FULL),
                    calibration_share=0.8)]
    obs = [observe(r, rig) for r in recs]
    rng = np.random.default_rng(5)
    diags = [o.u**2 + (2e-3 * o.values) ** 2 for o in obs]
    terms = [[rng.normal(size=len(o.names)) * o.u for _ in condition_kinds(o)] for o in obs]
    stacked = visit_covariance(obs, diags, terms)
    assert stacked is not None
    d, ts = stacked
    got = np.diag(d) + sum(np.outer(t, t) for t in ts)
    sizes = [len(o.names) for o in obs]
    at = np.concatenate([[0], np.cumsum(sizes)])
    for a, oa in enumerate(obs):
        for b, ob in enumerate(obs):
            block = got[at[a]:at[a + 1], at[b]:at[b + 1]]
            if a == b:
                own = np.diag(diags[a]) + sum(np.outer(t, t) for t in terms[a])
                np.testing.assert_allclose(block, own, rtol=1e-12, atol=1e-30)
                continue
            f = math.sqrt(oa.record.calibration_share * ob.record.calibration_share)
            want = np.zeros_like(block)
            for i, ni in enumerate(oa.names):
                for j, nj in enumerate(ob.names):
                    want[i, j] = f * oa.u[i] * ob.u[j] if ni == nj else 0.0
            kinds_b = condition_kinds(ob)
            for kind, t in zip(condition_kinds(oa), terms[a], strict=True):
                want += f * np.outer(t, terms[b][kinds_b.index(kind)])
            np.testing.assert_allclose(block, want, rtol=1e-12, atol=1e-30)


def _shared_visit(rig, seed: int) -> list[MeasurementRecord]:
    """Six healthy records whose instruments (every reading's, the load cell, the
    thermometer) are each off by one gain within its class for the whole visit."""
    from benchmarks.accuracy_joint import VisitInstruments

    visit = VisitInstruments(np.random.default_rng(seed))
    fields = (*FULL, "pump_flow")
    out = []
    for load in (2100.0, 4200.0, 6300.0):
        for temperature in (35.0, 55.0):
            values = readings(rig, {}, load, temperature)
            stated_load, stated_t = visit.stated(load, temperature)
            cond = OperatingCondition.from_readings({"oil_temperature": stated_t,
                                                     "load_force": stated_load})
            out.append(MeasurementRecord.from_readings("r", cond, visit.read(values, fields),
                                                       calibration_share=1.0))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_commissioning_counts_the_errors_its_records_share(seed: int) -> None:
    """Six healthy records of an as-built rig read by the same miscalibrated instruments,
    stating it (share 1): the commissioning's fit weighs the visit's whole covariance —
    an estimate and interval of their own, not the independent records' widened (a
    parameter pinned by differences between records gains where a common error cancels)
    — and the leakage and valve parameters' intervals hold the truth."""
    from tests.diagnostics.test_commissioning import TRUTH, true_rig

    documented, actual = reference_rig(), true_rig()
    recs = _shared_visit(actual, seed)
    shared = commission(documented, recs)
    apart = commission(documented, [replace(r, calibration_share=0.0) for r in recs])
    for name in ("cylinder.Lc", "valve.Ls", "valve.K", "pump.Rlp"):
        a = next(p for p in apart.parameters if p.name == name)
        s = next(p for p in shared.parameters if p.name == name)
        truth = documented.base[name] * TRUTH[name]
        assert s.low <= truth <= s.high, s
        assert (s.value, s.low, s.high) != pytest.approx((a.value, a.low, a.high), rel=1e-3)
