"""The named fault scenarios: what the help texts say each sets is what it sets."""

from __future__ import annotations

import re

import pytest

from sim.rigs import reference_rig
from sim.scenarios import FAULT_SUMMARY, FAULTS, fault_help, fault_overrides


@pytest.mark.parametrize("fault", FAULTS)
def test_each_fault_summary_names_what_the_fault_sets(fault: str) -> None:
    rig = reference_rig()
    overrides = fault_overrides(rig, fault)
    summary = FAULT_SUMMARY[fault]
    if not overrides:
        assert summary == "no override"
        return
    ((key, value),) = overrides.items()
    assert summary.startswith(key)
    base = rig.base[key]
    if (m := re.fullmatch(rf"{re.escape(key)} × (\d+)/(\d+), ([\d.]+) µm on the paper rig",
                          summary)):
        assert value == pytest.approx(base * float(m.group(1)) / float(m.group(2)), rel=1e-12)
        assert value == pytest.approx(float(m.group(3)) * 1e-6, rel=1e-15)  # the paper's own
    elif (m := re.match(rf"{re.escape(key)} × ([\d.]+)", summary)):
        assert value == pytest.approx(base * float(m.group(1)), rel=1e-12)
    else:
        m = re.match(rf"{re.escape(key)} ÷ ([\d.]+)", summary)
        assert m and value == pytest.approx(base / float(m.group(1)), rel=1e-12)
    # the paper-002 worn values are beyond the nominal ones
    if key in ("cylinder.cc", "valve.cv"):
        assert value > base


def test_the_help_text_lists_every_fault_with_its_setting() -> None:
    text = fault_help()
    for fault in FAULTS:
        assert f"{fault} ({FAULT_SUMMARY[fault]})" in text


def test_a_wear_is_a_wear_of_the_rig_it_is_run_on() -> None:
    """A rig with a 30 µm seal got the paper's 120 µm, 64× its leakage, and one of 130 µm
    a tighter seal (a rig author's pass): the faults scale the rig's own clearances."""
    import copy

    from sim.rigs import load_rig, reference_rig_document

    doc = copy.deepcopy(reference_rig_document())
    doc["name"] = "tight"
    doc["components"]["cylinder"]["parameters"]["cc"] = {"value": 30.0, "unit": "µm"}
    doc["components"]["valve"]["parameters"]["cv"] = {"value": 130.0, "unit": "µm"}
    rig = load_rig(doc)
    assert fault_overrides(rig, "worn_piston")["cylinder.cc"] == pytest.approx(30e-6 * 120 / 83)
    assert fault_overrides(rig, "worn_spool")["valve.cv"] == pytest.approx(130e-6 * 60 / 34)
