"""A component worn less than its worn range assumes: its value profiled from the rig
document's value (:mod:`diagnostics.healthy_end`), what the history keeps of it."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.diagnose import diagnose
from diagnostics.healthy_end import healthy_end_estimates
from diagnostics.observations import observe
from diagnostics.range_test import pinned
from diagnostics.ranking import Ranker
from sim.rigs import reference_rig
from tests.diagnostics.synth import FULL, NO_FLOW, record


@pytest.fixture(scope="module")
def rig():
    return reference_rig()


def test_a_seal_short_of_its_worn_range_is_estimated_where_it_is(rig):
    """Seal at leakage 1.2 × nominal (clearance 1.063 × the document's 83 µm; the worn
    range starts at 1.1 ×), no flow meters, noise-free: the cylinder fit sits on the worn
    range's start with an interval that excludes the truth; the profile from the
    document's value finds the truth (to the grid's refinement, 0.2 %) and its interval
    holds it."""
    cc = 83e-6 * 1.2 ** (1 / 3)
    d = diagnose(rig, [record(rig, {"cylinder.cc": cc}, load=4200.0, fields=NO_FLOW)])
    (fitted,) = next(f for f in d.hypotheses if f.name == "cylinder").parameters
    assert fitted.at_bound and fitted.low > cc  # the worn range's fit cannot hold it
    est = d.healthy_end["cylinder"]
    assert est.value == pytest.approx(cc, rel=2e-3)
    assert est.low < cc < est.high
    assert est.nominal == rig.base["cylinder.cc"] and est.severity == "none"
    assert not est.at_bound


def test_a_healthy_rig_is_estimated_at_its_document(rig):
    """Healthy rig, no flow meters, noise-free: every profiled component sits on its
    document value, the interval starting there exactly."""
    d = diagnose(rig, [record(rig, {}, load=2100.0, fields=NO_FLOW)])
    assert d.healthy_end  # the healthy rig's single fits all sit on their worn ranges' start
    for est in d.healthy_end.values():
        assert est.at_bound and est.value == est.low == est.nominal
        assert est.high > est.nominal and est.multiple == pytest.approx(1.0)


def test_a_slightly_leaking_pump_gives_its_slip_coefficient(rig):
    """Pump leakage 1.15 × nominal, no flow meters: the pump's fit sits on 1.33 ×; the slip
    coefficient the diagnosis reports is the profile's, at 1.15 × the nominal Cs (paper
    000 eq. 6: Cs = μ·k/(D·R_lp)), and its interval holds it."""
    d = diagnose(rig, [record(rig, {"pump.Rlp": rig.base["pump.Rlp"] / 1.15}, load=4200.0,
                              fields=NO_FLOW)])
    assert "pump" in d.healthy_end and d.pump_slip is not None
    mu = rig.fluid.dynamic_viscosity(40.0)
    nominal_cs = mu / (rig.base["pump.Vp"] * rig.base["pump.Rlp"])
    value, low, high = d.pump_slip
    assert low < 1.15 * nominal_cs < high
    assert value == pytest.approx(1.15 * nominal_cs, rel=0.03)


def test_a_fit_inside_its_worn_range_is_not_profiled(rig):
    """A seal at 2 × nominal leakage is fitted inside its worn range: no profile."""
    rec = record(rig, {"cylinder.cc": 83e-6 * 2.0 ** (1 / 3)}, load=4200.0, fields=NO_FLOW)
    ranker = Ranker(rig, [observe(rec, rig)])
    fits = ranker.rank()
    cyl = next(f for f in fits if f.name == "cylinder")
    assert pinned(ranker, cyl) == []
    assert "cylinder" not in healthy_end_estimates(ranker, fits)


def test_flow_meters_leave_the_closed_form_inversion_in_charge(rig):
    """With both flow meters the clearances come from paper 002 §2.7 in closed form: the
    cylinder and valve are not profiled."""
    d = diagnose(rig, [record(rig, {"cylinder.cc": 83e-6 * 1.2 ** (1 / 3)}, load=4200.0,
                              fields=FULL)])
    assert "cc" in d.direct and "cylinder" not in d.healthy_end
    assert "valve" not in d.healthy_end


def test_fast_and_direct_evaluators_agree(rig):
    """The profile on the compiled kernel and on direct steady solves: the same estimate
    and interval ends, within a twentieth of the interval."""
    rec = record(rig, {"valve.cv": 34e-6 * 1.2 ** (1 / 3)}, load=2100.0, fields=NO_FLOW)
    fast = diagnose(rig, [rec]).healthy_end["valve"]
    direct = diagnose(rig, [rec], method="direct").healthy_end["valve"]
    width = fast.high - fast.low
    for a, b in ((fast.value, direct.value), (fast.low, direct.low), (fast.high, direct.high)):
        assert abs(a - b) < 0.05 * width


def test_the_interval_covers_the_truth_under_instrument_noise(rig):
    """24 seals between the document's value and the worn range (leakage × 1-1.33), each
    read once with noise uniform within the instruments' classes, no flow meters: the
    95 % profile interval holds the truth in at least 21 (a binomial 95 % coverage falls
    below that with probability 0.03; the worn range's clipped fit held it in none of the
    ones it pinned)."""
    rng = np.random.default_rng(2026)
    held, profiled = 0, 0
    for k in np.linspace(1.0, 1.3, 24):
        cc = 83e-6 * k ** (1 / 3)
        rec = record(rig, {"cylinder.cc": cc}, load=float(rng.choice([2100.0, 4200.0])),
                     fields=NO_FLOW, rng=rng)
        d = diagnose(rig, [rec])
        est = d.healthy_end.get("cylinder")
        if est is None:
            continue
        profiled += 1
        held += est.low <= cc <= est.high
    assert profiled >= 12
    assert held >= profiled - 3


def test_the_closed_form_reads_the_rig_s_own_oil() -> None:
    """A rig on ISO VG 32 (26 cSt at 45 °C, not VG 46's 37): the closed-form clearances of
    a healthy, noise-free record are the document's. With VG 46's viscosity they read 14 %
    high (30 → 34 µm on a rig author's rig), and the history and trends kept that."""
    import copy

    from sim.rigs import load_rig, reference_rig_document

    doc = copy.deepcopy(reference_rig_document())
    doc["name"] = "vg32"
    doc["fluid"]["nu1"] = {"value": 32.0, "unit": "cSt", "source": "ISO VG 32"}
    doc["fluid"]["nu2"] = {"value": 5.4, "unit": "cSt", "source": "ISO VG 32 data sheet"}
    vg32 = load_rig(doc)
    d = diagnose(vg32, [record(vg32, {}, load=4200.0, temperature=45.0)])
    for key, name in (("cc", "cylinder.cc"), ("cv", "valve.cv")):
        assert d.direct[key].value == pytest.approx(vg32.base[name], rel=1e-6), key
