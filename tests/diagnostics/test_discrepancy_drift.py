"""The verdict after the base re-fit (diagnostics/discrepancy/drift.py): base drift, no
effect, or unexplained with the reason; the re-fit itself runs in test_discrepancy.py."""

from __future__ import annotations

import math

import pytest

from diagnostics.discrepancy.drift import BaseDrift, Drift
from diagnostics.discrepancy.gap import GapRow
from diagnostics.discrepancy.transient import is_significant
from diagnostics.discrepancy.verdict import OUTPUT_GAP, verdict

SIGMA = {"P1": 5e3, "v": 1e-3}
#: held-out gap against the stored rig: P1 at 40 σ
BEFORE = [GapRow("P1", "Pa", "steady", 40 * 5e3, 1e6), GapRow("v", "m/s", "steady", 1e-3, 4e-3)]


def _drift(value: float, error: float, rms: float, reason: str = "") -> Drift:
    p = BaseDrift("cylinder.Fu", "N", "seal friction", 136.2, value, error)
    within = rms <= OUTPUT_GAP
    return Drift([p], [GapRow("P1", "Pa", "steady", rms * 5e3, 3 * rms * 5e3)], [],
                 {"P1": rms, "v": 1.0}, within and p.significant, reason,
                 within and not p.significant)


def test_a_significant_change_that_closes_the_gap_is_base_drift() -> None:
    d = _drift(150.0, 1.0, 1.2)
    assert d.parameters[0].change == pytest.approx(150.0 / 136.2 - 1.0)
    outcome, message = verdict([], [], BEFORE, d.gap_after, {}, SIGMA, d)
    assert outcome == "base drift"
    assert "cylinder.Fu +10.1 %" in message and "1.2 σ" in message
    assert "POST /diagnose" in message and "left as it is" in message
    row = d.to_dict()["parameters"][0]
    assert row["unit"] == "N" and row["interval"] == pytest.approx([148.04, 151.96])


def test_no_significant_change_and_within_the_noise_is_no_effect() -> None:
    d = _drift(136.5, 1.0, 1.2, reason="re-fitted, no parameter moves significantly")
    assert d.unchanged and not d.accepted
    outcome, message = verdict([], [], BEFORE, [], {}, SIGMA, d)
    assert outcome == "no effect"
    assert "P1 (40.0 σ)" in message and d.reason in message


@pytest.mark.parametrize("rms", [OUTPUT_GAP + 0.5, 12.0])
def test_a_gap_the_re_fit_leaves_is_unexplained_with_the_reason(rms: float) -> None:
    d = _drift(150.0, 1.0, rms, reason="re-fitted, the held-out gap stays above the noise")
    assert not d.accepted and not d.unchanged
    outcome, message = verdict([], [], BEFORE, [], {}, SIGMA, d)
    assert outcome == "unexplained"
    assert message.endswith(d.reason)


def test_without_a_re_fit_the_verdict_is_as_before() -> None:
    outcome, _ = verdict([], [], BEFORE, [], {}, SIGMA, None)
    assert outcome == "unexplained"
    quiet = [GapRow("P1", "Pa", "steady", 5e3, 2e4)]
    assert verdict([], [], quiet, [], {}, SIGMA, None)[0] == "no effect"


def test_an_error_the_fit_could_not_estimate_is_not_a_significant_change() -> None:
    p = BaseDrift("valve.cv", "m", "spool clearance", 34e-6, 40e-6, math.nan)
    assert not p.significant


def test_a_change_inside_the_two_sided_one_percent_is_n_s_and_says_its_level() -> None:
    # 2.2 standard errors: outside the 95 % interval (1.96) but not significant at 1 %
    # (2.576), the level every effect's coefficient is held to; the answer says so
    p = BaseDrift("cylinder.cc", "m", "piston clearance", 83.0e-6, 83.0e-6 - 2.2e-7, 1e-7)
    _, hi = p.interval or (math.nan, math.nan)
    assert hi < p.stored and not p.significant
    d = Drift([p], [], [], {"P1": 1.0}, False, "")
    assert "1 %" in d.to_dict()["significance"] and "2.576" in d.to_dict()["significance"]
    assert not is_significant(2.5, 1.0) and is_significant(2.6, 1.0)
