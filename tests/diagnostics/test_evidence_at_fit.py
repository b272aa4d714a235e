"""The stated condition's uncertainty at each hypothesis's estimate in its evidence
(:mod:`diagnostics.evidence_at_fit`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.condition_interval import (
    SingleChecks,
    check_singles,
    covariances,
    point_parts,
)
from diagnostics.diagnose import diagnose
from diagnostics.evidence import map_log_evidence, map_support
from diagnostics.evidence_at_fit import evidence_at_fit, pair_at_fit, singles_log_evidence
from diagnostics.hypotheses import PARAMETERS
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.observations import observe
from diagnostics.quantity import Quantity
from diagnostics.ranking import Ranker
from sim.rigs import reference_rig
from tests.diagnostics.synth import NO_FLOW, readings

LOADS = (2100.0, 4200.0, 6300.0)


@pytest.fixture(scope="module")
def rig():
    return reference_rig()


def _visit(rig, leak, temperature, offsets, exact=False):
    """Noise-free records of a seal at ``leak`` × its laminar leakage at three loads, each
    stating its oil temperature ``offsets`` K off (exactly, when ``exact``)."""
    cc = PARAMETERS["cc"].nominal_value(rig) * leak ** (1.0 / 3.0)
    out = []
    for load, off in zip(LOADS, offsets, strict=True):
        vals = readings(rig, {"cylinder.cc": cc}, load, temperature)
        t = temperature + off
        cond = OperatingCondition.from_readings(
            {"oil_temperature": Quantity(t, 0.0) if exact else t,
             "load_force": Quantity(load, 0.0) if exact else load})
        out.append(observe(MeasurementRecord.from_readings("r", cond,
                                                           {k: vals[k] for k in NO_FLOW}), rig))
    return out


def test_with_the_healthy_covariance_the_map_quadrature_is_the_rankings(rig):
    """The single-fault quadrature on the map with the ranking's own covariance
    reproduces the ranking's (compiled) log-evidence: the two integrate the same thing."""
    ranker = Ranker(rig, _visit(rig, 3.0, 40.0, (1.0, -1.0, 1.0)))
    for f in ranker.rank():
        if len(f.parameters) != 1 or not math.isfinite(f.log_evidence):
            continue
        chi2 = sum(m.chi2_grid(m.maps.maps[f.name].pred) for m in ranker.models)
        assert map_log_evidence(chi2, map_support(ranker, f.name)) == \
            pytest.approx(f.log_evidence, abs=1e-6)


def test_an_exact_condition_moves_no_evidence(rig):
    """A condition stated exactly carries no uncertainty: the covariance at any estimate
    is the ranking's, and neither a single's nor a pair's evidence moves."""
    ranker = Ranker(rig, _visit(rig, 3.0, 40.0, (0.0, 0.0, 0.0), exact=True))
    fits = ranker.rank()
    shift = evidence_at_fit(ranker, fits, check_singles(ranker, fits)).shift
    assert shift
    assert max(abs(d) for d in shift.values()) < 1e-9


def test_an_exact_condition_leaves_a_pairs_interval_the_fits_own(rig):
    """With the condition stated exactly the sandwich σ of a pair is its Gauss-Newton σ:
    ±1.96 σ reproduces the ranking's interval of each parameter where it is not clipped
    (within 2 %: the ranking's Jacobian is the fit's, this one a central difference)."""
    ranker = Ranker(rig, _visit(rig, 3.0, 40.0, (0.0, 0.0, 0.0), exact=True))
    fits = ranker.rank()
    pairs = [f for f in fits if len(f.parameters) == 2 and math.isfinite(f.log_evidence)]
    checked = 0
    for f, got in zip(pairs, pair_at_fit(ranker, pairs), strict=True):
        assert got is not None
        for est, sd in zip(f.parameters, got[1], strict=True):
            p = PARAMETERS[est.name]
            lo, hi = (p.to_z(b) for b in p.worn_bounds(rig))
            z, zl, zh = p.to_z(est.value), p.to_z(est.low), p.to_z(est.high)
            if zl > lo + 1e-9 and zh < hi - 1e-9:  # not clipped at a bound
                assert 1.96 * sd == pytest.approx(0.5 * (zh - zl), rel=0.02)
                assert z - zl == pytest.approx(zh - z, rel=1e-6)
                checked += 1
    assert checked


def test_a_stated_condition_widens_a_worn_pairs_interval(rig):
    """A seal at 6 × its leakage, temperatures stated 1 K off: the pair cylinder+pump's
    seal interval in the answer holds ẑ ± 1.96 σ of the sandwich, which the stated
    condition at the worn estimate makes wider than the fit's own (measured ×3)."""
    recs = [o.record for o in _visit(rig, 6.0, 40.0, (1.0, -1.0, 1.0))]
    d = diagnose(rig, recs)
    pair = next(f for f in d.hypotheses if f.name == "cylinder+pump")
    (cyl,) = [e for e in pair.parameters if e.name == "cc"]
    exact = diagnose(rig, [o.record for o in _visit(rig, 6.0, 40.0, (1.0, -1.0, 1.0),
                                                    exact=True)])
    (cyl0,) = [e for e in next(f for f in exact.hypotheses if f.name == "cylinder+pump"
                               ).parameters if e.name == "cc"]
    p = PARAMETERS["cc"]
    assert p.to_z(cyl.high) - p.to_z(cyl.low) > 2.0 * (p.to_z(cyl0.high) - p.to_z(cyl0.low))


def test_a_pair_point_with_one_parameter_at_the_document_is_the_single(rig):
    """A two-parameter point (the seal's estimate, the document's pump leakage) solved by
    the compiled kernel predicts what the single fault's map does at that seal (within
    1e-5: the map's linear interpolation), and its derivative along the seal is the map's
    secant there (within 1 %)."""
    ranker = Ranker(rig, _visit(rig, 4.0, 40.0, (1.0, 1.0, -1.0)))
    fits = ranker.rank()
    cyl = next(f for f in fits if f.name == "cylinder")
    (est,) = cyl.parameters
    cc, leak = PARAMETERS["cc"], PARAMETERS["pump_leak"]
    z = (cc.to_z(est.value), leak.to_z(leak.nominal_value(rig)))
    parts = point_parts(ranker, [((cc, leak), z)])
    checks = check_singles(ranker, fits)
    k = list(checks.chi2).index("cylinder")
    for (y0, jac, _), (ys, js, _) in zip(parts, checks.parts, strict=True):
        np.testing.assert_allclose(y0[0], ys[k], rtol=1e-5)
        np.testing.assert_allclose(jac[0][:, 0], js[k], rtol=0.01)


def test_a_worn_seal_visit_is_a_seal_not_a_seal_and_a_pump(rig):
    """A seal at 6 × its leakage, noise-free, the visit's temperatures stated 1 K off
    (+, −, +: the thermometer's class bound).  Weighed by the healthy rig's sensitivity the
    readings ranked ``cylinder+pump`` first (p 0.97: the pump absorbed what the stated
    temperature does to the worn seal); with each hypothesis's covariance at its estimate
    the seal alone is named (measured p 0.996)."""
    ranker = Ranker(rig, _visit(rig, 6.0, 40.0, (1.0, -1.0, 1.0)))
    fits = ranker.rank()
    assert fits[0].name == "cylinder+pump"
    evidence_at_fit(ranker, fits, check_singles(ranker, fits))
    assert fits[0].name == "cylinder"
    assert fits[0].probability > 0.9
    assert sum(f.probability for f in fits) == pytest.approx(1.0)


def test_without_a_covariance_nothing_moves(rig):
    """A single whose covariance cannot be formed and a pair set where a reading has no
    prediction are left as ranked (None), not guessed."""
    ranker = Ranker(rig, _visit(rig, 3.0, 40.0, (1.0, -1.0, 1.0)))
    fits = ranker.rank()
    name = next(f.name for f in fits if len(f.parameters) == 1)
    nan_terms = [np.full((1, m.idx.size), np.nan) for m in ranker.models]
    nan_covs = [covariances(m, [t], 1) for m, t in zip(ranker.models, nan_terms, strict=True)]
    assert singles_log_evidence(ranker, [name], nan_covs) == [None]
    before = {f.name: f.log_evidence for f in fits}
    evidence_at_fit(ranker, fits, SingleChecks())
    pairs = [f for f in fits if len(f.parameters) == 2 and math.isfinite(f.log_evidence)]
    assert len(pair_at_fit(ranker, pairs)) == len(pairs)
    for f in fits:
        if len(f.parameters) == 1:
            assert f.log_evidence == before[f.name]


def test_the_answer_states_the_sigma_its_top_hypothesis_is_weighed_by(rig):
    """``reading_sigma`` (the console's grey bars) is the named fault's: for the worn
    seal's visit the working speed's σ at the fitted wear, several times the healthy
    rig's that the ranking started from, and no reading's σ below the instrument's."""
    obs = _visit(rig, 6.0, 40.0, (1.0, -1.0, 1.0))
    d = diagnose(rig, [o.record for o in obs])
    assert d.top.name == "cylinder"
    # its χ² at the estimate is the one the goodness test passed (measured 9.3 on 14
    # degrees of freedom, against 138 under the ranking's covariance), in the answer
    assert d.fit is not None and d.top.chi2_at_estimate == pytest.approx(d.fit.chi2)
    assert d.top.chi2_at_estimate < d.top.chi2 / 5.0
    pair = next(f for f in d.hypotheses if f.name == "cylinder+pump")
    assert math.isfinite(pair.chi2_at_estimate)
    assert d.to_dict()["hypotheses"][0]["chi2_at_estimate"] == d.top.chi2_at_estimate
    ranker = Ranker(rig, obs)
    for m, stated in zip(ranker.models, d.reading_sigma, strict=True):
        k = list(m.obs.names).index("speed_work")
        assert stated["speed_work"] > 2.0 * m.sigma[k]
        for name, u in zip(m.obs.names, m.obs.u, strict=True):
            assert stated[name] >= u
