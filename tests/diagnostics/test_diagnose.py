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


@pytest.mark.parametrize(("args", "kwargs", "error", "field", "words"), [
    ((None, "REC"), {}, "InputError", "rig", "compiled rig"),
    (("RIG", [{"p1": 11.88e5}]), {}, "MeasurementError", "records[0]", "MeasurementRecord"),
    (("RIG", "REC"), {"method": "fastest"}, "InputError", "method", "fast, direct"),
])
def test_an_argument_of_the_wrong_type_is_the_trees_error_naming_it(
        args: tuple, kwargs: dict, error: str, field: str, words: str) -> None:
    """None for the rig, a dict for a record and ``method="fastest"`` raised a bare
    AttributeError or ValueError (a library user's pass)."""
    from sim import errors

    rig = reference_rig()
    rec = record(rig, {}, load=2100.0, fields=FULL)
    given = [rig if a == "RIG" else [rec] if a == "REC" else a for a in args]
    with pytest.raises(getattr(errors, error)) as caught:
        diagnose(*given, **kwargs)
    assert type(caught.value).__name__ == error
    assert caught.value.field == field and words in caught.value.message
