"""What the history keeps of a diagnosis (:func:`app.services.diagnosis_estimates.estimates_of`): a
component's probability is that it is worn, alone or in a pair."""

from __future__ import annotations

import pytest

from app.services.diagnosis import estimates_of
from diagnostics.diagnose import diagnose
from sim.rigs import reference_rig
from tests.diagnostics.synth import readings, record


def test_a_component_in_a_likely_pair_is_likely_worn() -> None:
    rig = reference_rig()
    d = diagnose(rig, [record(rig, {"cylinder.cc": 110e-6, "valve.cv": 50e-6})])
    assert d.top.name == "cylinder+valve" and d.top.probability > 0.9
    single = {h.name: h.probability for h in d.hypotheses}
    estimates = {e.component: e for e in estimates_of(d)}
    for component in ("cylinder", "valve"):
        worn = sum(p for name, p in single.items() if component in name.split("+"))
        assert estimates[component].probability == pytest.approx(min(worn, 1.0), abs=1e-12)
        # the single fault alone is unlikely; the component is not (was p ≈ 1e-12)
        assert single[component] < 0.1 < 0.9 < estimates[component].probability


def test_a_joint_healthy_visit_keeps_each_clearance_where_the_readings_put_it() -> None:
    """A healthy visit at three loads stored its valve at the worn range's healthy end,
    37.39 µm [37.39, 38.60] for the document's 34 (an edge pass): a joint visit keeps the
    fits of all its records, and those pinned on the healthy end are profiled down to the
    document's value, as a single record's are."""
    rig = reference_rig()
    records = [record(rig, {}, load=load, temperature=40.0) for load in (2100.0, 4200.0, 6300.0)]
    d = diagnose(rig, records)
    assert d.top.name == "healthy"
    values = rig.values()
    for e in estimates_of(d):
        if e.quantity in ("cc", "cv"):
            truth = values[f"{e.component}.{e.quantity}"]
            assert e.low <= truth <= e.high, (e, truth)
            assert e.value == pytest.approx(truth, rel=0.02), (e, truth)


def test_an_unexplained_record_states_no_component_worn() -> None:
    """Healthy pressures and flows with the working stroke read as standing still: no
    hypothesis explains them, the answer's probability is 0, and so is every estimate's
    (it read "cylinder 237 µm, p = 1.0": an edge pass).  The hypotheses' own
    probabilities stay relative among themselves."""
    rig = reference_rig()
    values = readings(rig, {}, 2100.0, 40.0) | {"speed_work": 0.0}
    d = diagnose(rig, [record(rig, {}, values=values)])
    assert not d.explained and d.answer == "unexplained"
    assert sum(h.probability for h in d.hypotheses) == pytest.approx(1.0)
    estimates = estimates_of(d)
    assert estimates and all(e.probability == 0.0 for e in estimates)
    explained = diagnose(rig, [record(rig, {"valve.cv": 60e-6})])
    assert explained.explained
    assert max(e.probability for e in estimates_of(explained)) > 0.9
