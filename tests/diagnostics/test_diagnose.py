"""diagnostics.diagnose as a library user calls it."""

from __future__ import annotations

import pytest

from diagnostics.diagnose import diagnose
from sim.errors import MeasurementError
from sim.rigs import reference_rig
from tests.diagnostics.synth import FULL, record


def test_one_record_not_in_a_list_is_refused_with_the_call_to_make() -> None:
    """``diagnose(rig, rec)`` raised "'MeasurementRecord' object is not iterable" (a
    library user's pass)."""
    rig = reference_rig()
    rec = record(rig, {"valve.cv": 60e-6}, load=2100.0, fields=FULL)
    with pytest.raises(MeasurementError, match=r"diagnose\(rig, \[record\]\)") as caught:
        diagnose(rig, rec)  # type: ignore[arg-type]
    assert caught.value.field == "records"
    assert diagnose(rig, [rec]).top.name == "valve"
