"""The accuracy study's instruments-as-they-are suites (benchmarks/accuracy_noise.py): the
error draws they make, and the suites end to end on a few cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.accuracy import run_suites, stored_estimate
from benchmarks.accuracy_cases import AS_STATED, Noise, noisy, stated_condition
from benchmarks.accuracy_joint import VisitInstruments
from benchmarks.accuracy_noise import NOISIER, noise_study
from diagnostics.quantity import DEFAULT_INSTRUMENTS


def test_errors_as_stated_are_the_draws_the_main_suites_always_made() -> None:
    """The main suites' figures stay those of their seed: the class's errors are the
    uniform draws of ±half, number for number."""
    a, b = np.random.default_rng(3), np.random.default_rng(3)
    values = {"p1": 80e5, "flow_B": 4.6e-4, "speed_work": 0.1}
    got = noisy(values, tuple(values), a, AS_STATED)
    for f, v in values.items():
        inst = DEFAULT_INSTRUMENTS[f]
        half = inst.relative_bound * abs(v) + inst.absolute_bound
        assert got[f] == v + b.uniform(-half, half)
    assert stated_condition(4200.0, 45.0, a) == pytest.approx(
        (4200.0 + b.uniform(-42.0, 42.0), 45.0 + b.uniform(-1.0, 1.0)), abs=0.0)


@pytest.mark.parametrize(("noise", "bound", "sd"), [
    (Noise(2.0), 2.0, 2.0 / math.sqrt(3.0)),       # uniform within ±2a: σ = 2a/√3
    (Noise(1.5), 1.5, 1.5 / math.sqrt(3.0)),
    (Noise(1.0, "gauss"), math.inf, 1.0 / math.sqrt(3.0)),  # the class's σ, no bound
])
def test_the_draws_have_the_spread_they_claim(noise: Noise, bound: float, sd: float) -> None:
    rng = np.random.default_rng(7)
    x = np.array([noise.draw(rng, 1.0) for _ in range(40_000)])
    assert np.all(np.abs(x) <= bound)
    assert x.std() == pytest.approx(sd, rel=0.02)
    assert abs(x.mean()) < 4.0 * sd / math.sqrt(x.size)
    if noise.shape == "gauss":  # P(|z| > √3) = 0.0833: a share beyond the class bound
        assert np.mean(np.abs(x) > 1.0) == pytest.approx(0.0833, abs=0.006)


def test_a_visits_instruments_keep_their_gain_across_records() -> None:
    """A calibration error is the same gain in every record an instrument reads: the
    relative error of a relative-class reading and the thermometer's offset repeat."""
    visit = VisitInstruments(np.random.default_rng(5))
    low = visit.read({"p1": 40e5, "flow_B": 2e-4}, ("p1", "flow_B"))
    high = visit.read({"p1": 120e5, "flow_B": 6e-4}, ("p1", "flow_B"))
    assert low["p1"] / 40e5 == pytest.approx(high["p1"] / 120e5, rel=1e-14)
    assert low["flow_B"] / 2e-4 == pytest.approx(high["flow_B"] / 6e-4, rel=1e-14)
    assert low["p1"] != 40e5 and abs(low["p1"] / 40e5 - 1.0) <= 0.0025
    (l1, t1), (l2, t2) = visit.stated(2100.0, 45.0), visit.stated(6300.0, 45.0)
    assert t1 == t2 and abs(t1 - 45.0) <= 1.0
    assert l1 / 2100.0 == pytest.approx(l2 / 6300.0, rel=1e-14)
    # a stroke that did not move has no speed to read, as in the independent draws
    assert visit.read({"speed_work": 0.0}, ("speed_work",)) == {}


def test_the_suites_run_end_to_end_and_report_every_draw() -> None:
    out = noise_study(2, 1, np.random.default_rng(11), run_suites,
                      {"full": [], "no_flow_meters": [], "ratio_alone": []}, stored_estimate,
                      n_commission=1)
    assert set(out["in_library"]) == {"class, uniform (main)", *NOISIER}
    for label in NOISIER:
        for sname, fig in out["in_library"][label].items():
            assert fig["n"] == 2 and fig["server_errors"] == 0, (label, sname)
    assert out["joint"]["visits"] == 1
    assert set(out["joint"]["shared"]) == {"visits", "full", "no_flow_meters", "stated"}
    assert set(out["joint"]["shared"]["stated"]) == {"full", "no_flow_meters"}
    assert set(out["joint"]["independent"]) == {"visits", "full", "no_flow_meters"}
    comm = out["commissioning_shared"]
    assert comm["seeds"] == 1 and comm["stated"]["pinned"] >= 3
    assert 0.0 <= comm["stated"]["held"] <= 1.0
