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
    if (m := re.fullmatch(rf"{re.escape(key)} = ([\d.]+) µm", summary)):
        assert value == pytest.approx(float(m.group(1)) * 1e-6, rel=1e-12)
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
