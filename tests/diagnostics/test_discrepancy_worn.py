"""The worn rig document of diagnostics/discrepancy/worn.py; the whole second pass runs in
test_discrepancy.py."""

from __future__ import annotations

import pytest

from diagnostics.discrepancy.drift import BaseDrift, Drift
from diagnostics.discrepancy.worn import WORN_SOURCE, worn_document
from sim.rigs import load_rig, reference_rig_document


def test_the_worn_document_states_each_value_in_its_own_unit() -> None:
    """A rig document may state the clearance in µm; the re-fitted value is in metres and
    is written with its unit (writing the value alone would have read 120e-6 µm)."""
    doc = reference_rig_document()
    doc["components"]["cylinder"]["parameters"]["cc"] = {"value": 83.0, "unit": "um",
                                                         "source": "data sheet"}
    wear = Drift([BaseDrift("cylinder.cc", "m", "piston clearance", 83e-6, 120e-6, 1e-8)],
                 [], [], {}, True, "")
    worn = worn_document(doc, wear)
    assert load_rig(worn).base["cylinder.cc"] == pytest.approx(120e-6)
    assert worn["components"]["cylinder"]["parameters"]["cc"]["source"] == WORN_SOURCE
    # the given document is left as it was
    assert doc["components"]["cylinder"]["parameters"]["cc"]["value"] == 83.0
    assert load_rig(doc).base["cylinder.cc"] == pytest.approx(83e-6)
