"""Posterior probabilities from evidences and the fleet prior (diagnostics.evidence)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from diagnostics.diagnose import diagnose
from diagnostics.evidence import FLEET_PRIOR, posterior, whitening
from diagnostics.hypotheses import HYPOTHESES
from diagnostics.observations import observe
from diagnostics.ranking import HypothesisFit, Ranker
from sim.rigs import reference_rig
from tests.diagnostics.synth import FULL, readings, record

BY_NAME = {h.name: h for h in HYPOTHESES}


def _fit(name: str, log_z: float, observable: bool = True) -> HypothesisFit:
    return HypothesisFit(BY_NAME[name], chi2=0.0, log_evidence=log_z, parameters=[],
                         predicted=[], observable=observable)


def test_the_fleet_prior_is_a_distribution_over_the_library() -> None:
    assert set(FLEET_PRIOR) == set(BY_NAME)
    assert math.isclose(sum(FLEET_PRIOR.values()), 1.0)


def test_equal_priors_give_the_evidence_ratio_by_hand() -> None:
    # Z_valve / Z_healthy = e² : P(valve) = e² / (1 + e²)
    fits = [_fit("healthy", -3.0), _fit("valve", -1.0), _fit("pump", -1.0, observable=False)]
    posterior(fits)
    assert fits[1].probability == pytest.approx(math.exp(2) / (1 + math.exp(2)), rel=1e-12)
    assert fits[0].probability == pytest.approx(1 / (1 + math.exp(2)), rel=1e-12)
    assert fits[2].probability == 0.0  # not observable: no share


def test_a_stated_prior_multiplies_the_evidence() -> None:
    fits = [_fit("healthy", 0.0), _fit("valve", 0.0)]
    posterior(fits, {"healthy": 0.75, "valve": 0.25})
    assert fits[0].probability == pytest.approx(0.75)
    # a hypothesis the prior leaves out gets nothing
    fits = [_fit("healthy", 0.0), _fit("valve", 5.0)]
    posterior(fits, {"healthy": 1.0})
    assert (fits[0].probability, fits[1].probability) == (1.0, 0.0)


def test_no_finite_evidence_gives_no_probability() -> None:
    fits = [_fit("healthy", -math.inf), _fit("valve", -math.inf)]
    posterior(fits)
    assert all(f.probability == 0.0 for f in fits)


def test_a_diagnosis_uses_the_fleet_prior_over_its_evidences() -> None:
    rig = reference_rig()
    d = diagnose(rig, [record(rig, {"valve.cv": 55e-6}, load=4.2e3, fields=FULL)])
    obs = [f for f in d.hypotheses if f.observable]
    top = max(f.log_evidence for f in obs)
    total = sum(math.exp(f.log_evidence - top) for f in obs)
    for f in obs:
        assert f.probability == pytest.approx(math.exp(f.log_evidence - top) / total, rel=1e-9)


def test_whitening_inverts_the_covariance_by_hand() -> None:
    diag = np.array([4.0, 9.0, 1.0])
    t = np.array([1.0, -2.0, 0.5])
    sigma, w = whitening(diag, [t])
    cov = np.diag(diag) + np.outer(t, t)
    assert np.allclose(sigma, np.sqrt(np.diag(cov)))
    assert np.allclose(w.T @ w, np.linalg.inv(cov))


def test_a_term_too_large_to_factor_keeps_the_marginal_sigma() -> None:
    sigma, w = whitening(np.array([1.0, 1.0]), [np.array([1e100, 1.0])])
    assert np.allclose(w, np.diag(1.0 / sigma))


def test_a_thermometer_error_counts_once_not_once_per_reading() -> None:
    # readings of the healthy rig at 41 °C, stated as 40 °C ± 1 °C (class bound, σ_T = 1/√3
    # K): with r = s·δ along the temperature sensitivity s, χ² = δ² a / (1 + a σ_T²),
    # a = sᵀD⁻¹s, which stays below δ²/σ_T² = 3 however many readings the error moves;
    # independent σ per reading count the one error once per reading
    rig = reference_rig()
    stated = record(rig, {}, load=4.2e3, temperature=40.0, fields=FULL,
                    values=readings(rig, {}, 4.2e3, 41.0))
    ranker = Ranker(rig, [observe(stated, rig)])
    chi2, _ = ranker._healthy()
    assert 1.0 < chi2 < 3.0 * 1.02  # linearised sensitivity: 2 % margin
    m = ranker.models[0]
    naive = float(np.sum(((m.obs.values - m.maps.nominal[m.idx]) / m.sigma) ** 2))
    assert naive > 1.3 * chi2


def test_a_relief_setting_that_would_not_open_takes_no_share_of_a_healthy_record() -> None:
    # at 6.3 kN the healthy pump pressure (≈ 31 bar) lies inside the worn range of the
    # setting (21-66.5 bar): settings above it never open and leave the healthy readings
    # exactly; they cannot be blamed, and the statement says so
    rig = reference_rig()
    d = diagnose(rig, [record(rig, {}, load=6.3e3, temperature=30.0, fields=FULL,
                              rng=np.random.default_rng(3))])
    setting = next(f for f in d.hypotheses if f.name == "relief_setting")
    assert setting.observable
    assert setting.probability < 0.05
    assert d.top.name == "healthy"
    assert any("does not open at these conditions" in s for s in d.isolability.statements)


def test_a_setting_that_opens_is_still_found_with_its_evidence_over_the_acting_range() -> None:
    rig = reference_rig()
    pset = 0.40 * rig.base["relief.Pset"]  # 28 bar, below the ≈ 31 bar the load needs
    d = diagnose(rig, [record(rig, {"relief.Pset": pset}, load=6.3e3, temperature=30.0,
                              fields=FULL, rng=np.random.default_rng(4))])
    assert d.top.name == "relief_setting"
    (est,) = d.top.parameters
    assert est.low <= pset <= est.high
