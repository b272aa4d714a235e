"""Mistakes in the readings' units, named when nothing else explains the readings
(diagnostics/unit_mistakes.py)."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.condition_interval import check_singles
from diagnostics.diagnose import diagnose
from diagnostics.goodness import goodness_of_fit
from diagnostics.measurement import PRESSURE_FIELDS
from diagnostics.observations import observe, rig_limits
from diagnostics.ranking import Ranker
from diagnostics.unit_mistakes import ATMOSPHERE, ATMOSPHERE_U
from sim.rigs import reference_rig
from tests.diagnostics.synth import FULL, NO_FLOW, readings, record


@pytest.fixture(scope="module")
def rig():
    return reference_rig()


def test_the_atmosphere_is_the_standard_one_within_its_stated_bound() -> None:
    assert ATMOSPHERE == 101_325.0  # ISO 2533 at sea level
    assert ATMOSPHERE_U * np.sqrt(3.0) == pytest.approx(10_000.0)


@pytest.mark.parametrize("fields", [FULL, NO_FLOW])
@pytest.mark.parametrize(("faults", "truth"), [({}, "healthy"),
                                               ({"valve.cv": 50e-6}, "valve")])
def test_absolute_pressures_are_named_with_the_fault_they_hide(rig, fields, faults, truth):
    """A worn spool's (or a healthy rig's) readings with every pressure stated absolute at
    an atmosphere of 98.7 kPa (a rig at ~250 m): not explained — a chamber's 1.2 bar back
    pressure reads 2.2 bar — and the answer names the mistake, with the hypothesis that
    explains the readings once an atmosphere is taken off."""
    vals = readings(rig, faults, 4200.0, 45.0)
    absolute = dict(vals, **{k: vals[k] + 98.7e3 for k in PRESSURE_FIELDS})
    d = diagnose(rig, [record(rig, {}, load=4200.0, temperature=45.0, fields=fields,
                              values=absolute, rng=np.random.default_rng(2))])
    assert not d.explained and d.fit is not None
    (m,) = d.fit.unit_mistakes
    assert m.mistake == "absolute_pressure" and m.chi2 <= m.limit
    if fields == FULL:
        assert m.hypothesis == truth
    text = d.to_dict()["misfit"]
    assert "Likely: the pressures look absolute" in text and "send gauge pressures" in text
    # the answer is not corrected: a likely cause, not a measured fact
    assert d.answer == "unexplained"


def test_a_temperature_in_fahrenheit_is_named_and_converted(rig):
    vals = readings(rig, {"cylinder.cc": 120e-6}, 4200.0, 30.0)
    d = diagnose(rig, [record(rig, {}, load=4200.0, temperature=86.0, values=vals,
                              rng=np.random.default_rng(4))])
    assert not d.explained and d.fit is not None
    (m,) = d.fit.unit_mistakes
    assert m.mistake == "fahrenheit" and m.hypothesis == "cylinder"
    assert "86 °F is 30.0 °C" in m.statement


def test_a_misfit_of_another_kind_names_no_mistake(rig):
    """A gauge 6 % off, and a relief setting far below the prior: not explained, and
    neither correction explains them (the study's 605 such answers named none)."""
    vals = readings(rig, {"valve.cv": 45e-6}, 4200.0, 45.0)
    gauge = diagnose(rig, [record(rig, {}, load=4200.0, temperature=45.0,
                                  values=dict(vals, p1=vals["p1"] * 1.06))])
    assert not gauge.explained and gauge.fit is not None
    assert gauge.fit.unit_mistakes == [] and "Likely:" not in gauge.fit.statement


def test_readings_that_are_explained_try_no_correction(rig):
    rec = record(rig, {"valve.cv": 50e-6}, load=4200.0, temperature=45.0,
                 rng=np.random.default_rng(1))
    ranker = Ranker(rig, [observe(rec, rig)])
    fits = ranker.rank()
    checks = check_singles(ranker, fits)

    def never() -> list:
        raise AssertionError("corrections tried on explained readings")

    gof = goodness_of_fit(ranker, fits, at_fit=checks.chi2,
                          at_fit_sigma=checks.reading_sigma(), mistakes=never)
    assert gof.explained and gof.unit_mistakes == []


def test_records_that_cannot_carry_a_mistake_are_not_corrected(rig, monkeypatch):
    """Readings without a pressure carry no absolute pressure, and 20 °C read as °F would be
    −6.7 °C, outside 0-90 °C: nothing is re-ranked (an honest cold record is never re-read
    as °F); 40 °C (4.4 °C as °F) and a pressure are tried."""
    import diagnostics.unit_mistakes as um

    tried: list[int] = []

    class Counting(um.Ranker):  # type: ignore[misc]
        def __init__(self, *args, **kwargs):
            tried.append(1)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(um, "Ranker", Counting)
    limits = rig_limits(rig)
    vals = readings(rig, {}, 2100.0, 20.0)
    flows_only = record(rig, {}, load=2100.0, temperature=20.0,
                        fields=("flow_B", "flow_C", "speed_work", "speed_return"), values=vals)
    assert um.unit_mistakes(rig, [flows_only], 0.002, "fast", limits) == []
    assert tried == []
    warm = record(rig, {}, load=2100.0, temperature=40.0)
    assert um.unit_mistakes(rig, [warm], 0.002, "fast", limits) == []  # explained as is
    assert len(tried) == 2
