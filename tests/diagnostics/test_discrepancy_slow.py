"""Stribeck friction confirmed on stick-slip-free statistics of timed slow strokes."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.discrepancy_study import SLOW, SLOW_SWITCH, SPEED, _doc_with
from diagnostics.discrepancy import discover
from diagnostics.discrepancy.noise import sigmas
from diagnostics.discrepancy.slow import is_slow, slow_chi2, slow_records
from diagnostics.discrepancy.synthetic import synthesize
from diagnostics.discrepancy.workflow import _channels
from sim.rigs import load_rig, reference_rig, reference_rig_document
from sim.rigs.assembly import Condition

#: the study's design with its two slow strokes (HYDRODIAG_SLOW=1): load [N], oil
#: temperature [°C], pump speed [rad/s], timed switch [s] or None
DESIGN = ((2100.0, 40.0, 0.8 * SPEED, None), (4200.0, 50.0, 0.9 * SPEED, None),
          (6300.0, 60.0, SPEED, None), (2100.0, 40.0, SLOW * SPEED, SLOW_SWITCH),
          (2100.0, 60.0, SLOW * SPEED, SLOW_SWITCH))


def _records(doc: dict, seed: int) -> list:
    rig = load_rig(doc)
    rng = np.random.default_rng(seed)
    return [synthesize(rig, Condition(load=L, oil_temperature=T, pump_speed=w), rng=rng,
                       name=f"{L:.0f} N {T:.0f} °C {w:.0f} rad/s", t_max=sw)
            for L, T, w, sw in DESIGN]


def test_only_stribeck_friction_is_a_slow_speed_entry() -> None:
    assert is_slow(["stribeck_friction.F_s"])
    assert not is_slow(["seal_friction_pressure.k_p"])
    assert not is_slow([])


def test_slow_statistics_separate_the_effect_from_its_absence() -> None:
    """On the slow strokes of data hiding 50 N of Stribeck friction, the statistics of
    the rig without the effect are off by more than 3× the χ² of the rig with it.

    Not within the noise even with the effect: χ² ≈ 12 000 on 42 degrees of freedom
    (seed 7) — the block errors understate what a re-simulation of stick-slip can match
    (the phase switch is known to a sample); the slow refit inflates its interval by
    χ²/dof, and its value lands 15-20 % low."""
    recs = _records(_doc_with("stribeck_friction", 50.0), 7)
    slow = slow_records(recs, reference_rig())
    assert len(slow) == 2
    channels = _channels(recs)
    sig = sigmas(recs, channels)
    with_effect, dof = slow_chi2(load_rig(_doc_with("stribeck_friction", 50.0)), slow,
                                 channels, sig)
    without, _ = slow_chi2(reference_rig(), slow, channels, sig)
    # mean and spread per channel of each slow phase long enough for the blocks
    assert dof % (2 * len(channels)) == 0 and dof >= 2 * 2 * len(channels)
    assert without > 3.0 * with_effect
    assert without > 100.0 * dof


def test_hidden_stribeck_friction_is_named_from_the_slow_strokes() -> None:
    truth = 50.0
    d = discover(reference_rig_document(), _records(_doc_with("stribeck_friction", truth), 7),
                 bootstrap=10)
    assert [n.name for n in d.named] == ["stribeck_friction"]
    n = d.named[0]
    assert n.balance == "piston_force"
    # the equation error and the statistics both land 15-20 % low (smoothed stick-slip)
    assert n.value == pytest.approx(truth, rel=0.25)


def test_slow_strokes_without_an_effect_name_nothing() -> None:
    d = discover(reference_rig_document(), _records(reference_rig_document(), 5000),
                 bootstrap=10)
    assert d.named == []
