"""The same question gives the same answer: whatever ran before in the process, whatever
the interpreter's hash seed."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from diagnostics.diagnose import diagnose
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.signatures import GRAPH_PARAMETERS, evaluator
from diagnostics.slip import rig_slip_coefficient
from sim.rigs import Condition, reference_rig
from tests.diagnostics.synth import record

ROOT = Path(__file__).resolve().parents[2]
#: a condition no other test diagnoses at, so that the first diagnosis here finds the
#: compiled maps as they were built: load [N], oil temperature [°C]
LOAD, TEMPERATURE = 2345.6, 37.3
#: readings of the records: flows, speeds and pressures (the README's set)
FIELDS = ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "speed_work", "speed_return")


def _record(faults: dict[str, float], scale: float) -> MeasurementRecord:
    """Readings of the reference rig with ``faults`` (graph values) at the test's condition,
    each read ``scale`` times its true value (within the default instruments' bounds)."""
    rig = reference_rig()
    vals = evaluator(rig, Condition(load=LOAD, oil_temperature=TEMPERATURE))(
        np.array([faults.get(n, rig.base[n]) for n in GRAPH_PARAMETERS]))
    cond = OperatingCondition.from_readings({"oil_temperature": TEMPERATURE,
                                             "load_force": LOAD})
    return MeasurementRecord.from_readings("r", cond, {f: vals[f] * scale for f in FIELDS})


def _text(d: Any) -> str:
    """Every number and string of a diagnosis (NaN as text, so that it equals itself)."""
    return json.dumps(d.to_dict(), default=str)


def test_a_diagnosis_does_not_depend_on_what_was_diagnosed_before_at_its_condition() -> None:
    """The fast path's Newton states and chord Jacobians were carried from one diagnosis
    to the next at a condition: the same record a second time differed by up to 2e-5
    relative in a χ² and 1.7e-6 in an interval's bound, and a record after another one
    differed from itself alone.  Each diagnosis now starts where the maps were built."""
    rig = reference_rig()
    worn_valve = _record({"valve.cv": 55e-6}, 1.002)
    worn_cylinder = _record({"cylinder.cc": 115e-6}, 0.999)
    alone = _text(diagnose(rig, [worn_valve]))
    assert _text(diagnose(rig, [worn_valve])) == alone
    diagnose(rig, [worn_cylinder])
    diagnose(rig, [worn_cylinder, worn_valve])
    assert _text(diagnose(rig, [worn_valve])) == alone


_SCRIPT = """
import json, sys
from diagnostics.diagnose import diagnose
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from sim.rigs import reference_rig
from sim.steady import steady_cycle
cond = OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": 2100.0})
rec = MeasurementRecord.from_readings("rig-1", cond, {
    "pump_pressure": 14.50e5, "p1": 11.88e5, "p2": 1.202e5, "flow_B": 4.643e-4,
    "flow_C": 4.172e-4, "speed_work": 0.1881, "speed_return": 0.2177})
rig = reference_rig()
out = {"diagnosis": diagnose(rig, [rec]).to_dict(),
       "steady": steady_cycle(rig, {"cylinder.cc": 120e-6}).working}
sys.stdout.write(json.dumps(out, default=str))
"""


def test_answers_do_not_depend_on_the_hash_seed() -> None:
    """A diagnosis and a steady cycle in two interpreters with different hash seeds (the
    order of sets and of str-keyed hashing): the same text, every digit."""
    outs = []
    for seed in ("1", "2"):
        env = os.environ | {"PYTHONHASHSEED": seed}
        run = subprocess.run([sys.executable, "-c", _SCRIPT], cwd=ROOT, env=env,
                             capture_output=True, text=True, check=True)
        outs.append(run.stdout)
    assert outs[0] == outs[1]
    assert json.loads(outs[0])["diagnosis"]["top"] == "valve"


def test_a_joint_visit_keeps_the_same_numbers_whatever_the_records_order() -> None:
    """A joint visit's closed-form clearances came from its first record and its slip
    coefficient was stated at the first record's oil temperature: three records of
    different wear listed forwards and reversed stored cv 60 µm and 34 µm.  Now the
    clearance is that of the most precise record's inversion (its standard uncertainty the
    least of the records'), Cs is stated at the records' mean temperature (Cs = μ(T)·k /
    (D·R_lp), paper 000 eq. 6 on the rig's pump), and both orders give them alike."""
    rig = reference_rig()
    visit = [record(rig, {"valve.cv": cv}, load=load, temperature=theta)
             for cv, load, theta in ((60e-6, 2100.0, 35.0), (45e-6, 4200.0, 45.0),
                                     (34e-6, 6300.0, 55.0))]
    forwards, backwards = diagnose(rig, visit), diagnose(rig, visit[::-1])
    alone = [diagnose(rig, [r]).direct for r in visit]
    for key in ("cc", "cv"):
        best = min(alone, key=lambda d: d[key].u)[key]
        for d in (forwards, backwards):
            assert (d.direct[key].value, d.direct[key].low, d.direct[key].high) == (
                best.value, best.low, best.high)
    assert forwards.pump_slip is not None and backwards.pump_slip is not None
    np.testing.assert_allclose(forwards.pump_slip, backwards.pump_slip, rtol=1e-6)
    (k,) = (forwards.healthy_end["pump"] if "pump" in forwards.healthy_end else
            next(f for f in forwards.hypotheses if f.name == "pump").parameters[0],)
    assert forwards.pump_slip[0] == pytest.approx(
        rig_slip_coefficient(rig, 45.0, k.value), rel=1e-12)
    said = [n for n in forwards.notes if n.startswith("the direct inversion of cv")]
    assert said and "the most precise of the 3" in said[0]
