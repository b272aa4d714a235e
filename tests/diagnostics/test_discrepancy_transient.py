"""The output-error screen of the build-up effects (:mod:`diagnostics.discrepancy.transient`).

On the hidden-effect bench's design (three full strokes and four dwell records; the
study's seed of its first 8 σ case) entrained air at its "8 σ" strength leaves 8 σ in
steady motion and hundreds of σ in the build-up after each switch, which every balance
leaves out: the chamber balance proposes nothing, the screen re-fits it by re-simulation.
"""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.discrepancy_study import _case, _doc_with
from diagnostics.discrepancy import Discovery, discover
from diagnostics.discrepancy.transient import build_up_effects
from sim.rigs import reference_rig_document
from tests.diagnostics.test_discrepancy import _records

#: the bench's 8 σ free-air fraction: 8 × the calibrated 1 σ of 3.2027e-5 [-]
ALPHA = 2.5622e-4


def assert_named_alone(d: Discovery, effect: str, param: str, truth: float, rel: float) -> None:
    """``effect`` is the one name, its value within ``rel`` of ``truth`` and inside its
    stated interval, plausible, and the new rig document carries that value."""
    assert [n.name for n in d.named] == [effect]
    n = d.named[0]
    assert n.value == pytest.approx(truth, rel=rel)
    assert n.interval[0] <= truth <= n.interval[1]
    assert n.plausible
    assert d.verdict == "named"
    assert d.rig_document["effects"][effect]["parameters"][param]["value"] == n.value


def test_the_screen_covers_the_build_up_entries() -> None:
    assert [e.name for e in build_up_effects()] == ["entrained_air"]


def test_entrained_air_no_balance_sees_is_named_by_re_simulation() -> None:
    """Named by the screen, within 5 % of the truth and inside its stated interval (the
    re-fit scans the compared part's cost near the build-up's valley, which lies ~10 %
    off; the error counts that disagreement), the held-out gap shrinking; the report's
    undefined equation-error figures are null, not NaN."""
    d = _case(_doc_with("entrained_air", ALPHA), 1007)
    assert_named_alone(d, "entrained_air", "alpha", ALPHA, 0.05)
    assert d.named[0].balance == "output error (build-up screen)"
    assert "output-error screen" in d.message
    named = d.to_dict()["named"][0]
    assert named["equation_error"] is None and named["inclusion"] is None
    assert np.isfinite(named["t"])


def test_a_gap_the_screened_effect_does_not_close_is_not_named() -> None:
    """Hoses at half bore (outside the library) on a three-record design: the re-fitted air
    fraction shrinks the held-out gap in the build-up too little, or leaves the steady
    pressures many σ off, so it is not named and the answer says why."""
    recs = _records(reference_rig_document(), 4,
                    overrides={"hose_A.d": 0.0127 / 2, "hose_B.d": 0.0127 / 2})
    d = discover(reference_rig_document(), recs, bootstrap=10)
    assert d.named == []
    assert d.verdict == "unexplained"
    why = d.message.partition("build-up effects re-simulated and not confirmed: ")[2]
    assert why.startswith(("entrained_air (leaves the held-out gap above the noise",
                           "entrained_air (held-out gap ratio")), d.message


def test_a_build_up_effect_that_leaves_the_steady_gap_is_not_confirmed_from_its_balance() -> None:
    """Strong entrained air (α 0.005, a user pass's case): the chamber balance proposes it,
    and its output-error re-fit from there landed 18× low (seed 2) or 23 % low, shrinking the
    build-up gap enough to be confirmed while the held-out steady gap stayed at 3.2 σ or
    grew; it was named with an interval that missed the truth, and stored.  Now that
    proposal is not confirmed and the screen of the build-up effects re-fits it from its
    own scan: named within 1 %, the truth inside its interval, the steady gap at the noise."""
    truth = 0.005
    recs = _records(_doc_with("entrained_air", truth), 2)
    d = discover(reference_rig_document(), recs, bootstrap=10)
    assert_named_alone(d, "entrained_air", "alpha", truth, 0.01)
    steady = {r.channel: r.rmse for r in d.gap_after if r.region == "steady"}
    assert steady["Q_meter_C"] < 1.5 * 8.3e-7
