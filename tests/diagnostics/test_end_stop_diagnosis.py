"""Stalled strokes are diagnosed (issue 11): a worn seal or spool whose rig cannot push its
load sits on its end stop; its readings are those of the transient model's settled stall
(as a rig reads them: no working speed), and the diagnosis explains them with the
end-stop state, names the fault and brackets its size.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from benchmarks.accuracy_cases import noisy, transient_readings
from diagnostics.diagnose import diagnose
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from sim.rigs import reference_rig

#: full sensors of the accuracy study (a stalled record has no speed and no ratio)
FIELDS = ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "pump_flow", "speed_work",
          "speed_return", "velocity_ratio")


@pytest.mark.parametrize(("graph", "value", "name"), [
    ("cylinder.cc", 250e-6, "cylinder"),
    ("cylinder.cc", 200e-6, "cylinder"),
    ("valve.cv", 90e-6, "valve"),
])
def test_a_stalled_stroke_is_explained_and_its_leak_sized(graph: str, value: float,
                                                         name: str) -> None:
    rig = reference_rig()
    load, temp = 4200.0, 55.0
    tr = transient_readings(rig, {graph: value}, load, temp)
    assert "working" in tr.stalled and "speed_work" in tr.values
    assert tr.values["speed_work"] < 1e-6  # the transient's piston sits still
    oc = OperatingCondition.from_readings({"oil_temperature": temp, "load_force": load})
    rng = np.random.default_rng(7)
    rec = MeasurementRecord.from_readings("r", oc, noisy(tr.values, FIELDS, rng))
    d = diagnose(rig, [rec])
    assert d.explained, d.fit.statement if d.fit else ""
    assert d.top.name == name
    (est,) = d.top.parameters
    assert est.low <= value <= est.high
    assert any("end stop" in n for n in d.regime_notes)
    # the held span of a clearance in µm, as an engineer reads it (was "0.0002443 … m")
    spans = [re.search(r"from ([\d.]+) µm to ([\d.]+) µm", n) for n in d.regime_notes]
    assert any(m and 30.0 < float(m.group(1)) < float(m.group(2)) < 1000.0 for m in spans)
    assert "Model limit" not in (d.fit.statement if d.fit else "")


def test_maps_follow_direct_solves_across_the_stall_ridge() -> None:
    """The seal and spool maps at a load the worn end cannot push: the held range is
    mapped in its end-stop state (speed 0) and the interpolation follows direct solves
    across the ridge and the creep band before it (split there, not smeared) to 1e-3 of
    each reading's range."""
    from diagnostics.fastpath.maps import fast_maps
    from diagnostics.signatures import SignatureMaps
    from sim.rigs import Condition

    rig = reference_rig()
    cond = Condition(load=4200.0, oil_temperature=55.0)
    fast, direct = fast_maps(rig, cond), SignatureMaps(rig, cond)
    for name in ("cylinder", "valve"):
        hm = fast.maps[name]
        assert 0.1 < hm.held[0] < 0.9  # both states inside the prior range
        (p,) = hm.params
        truth = np.array([direct.predict((p,), np.array([p.from_z(float(z))]))
                          for z in hm.axes[0]])
        assert np.isfinite(hm.pred).all() and np.isfinite(truth).all()
        scale = np.max(np.abs(truth), axis=0)
        err = np.abs(hm.pred - truth) / np.where(scale > 0, scale, 1.0)
        assert float(err.max()) < 1e-3, (name, err.max(axis=0))
        assert float(hm.pred[:, 6].min()) == 0.0  # held: speed exactly 0, never negative
