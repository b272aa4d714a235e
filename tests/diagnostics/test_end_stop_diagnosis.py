"""Stalled strokes are diagnosed (issue 11): a worn seal or spool whose rig cannot push its
load sits on its end stop; its readings are those of the transient model's settled stall
(as a rig reads them: no working speed), and the diagnosis explains them with the
end-stop state, names the fault and brackets its size.
"""

from __future__ import annotations

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
    assert "Model limit" not in (d.fit.statement if d.fit else "")
