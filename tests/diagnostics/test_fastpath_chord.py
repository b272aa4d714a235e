"""The chord Newton of the maps' grid solves (diagnostics.fastpath.chord) gives the maps of
the damped solver, near the stall ridge included, and settles most of the solves."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.fastpath.maps import FastMaps, phase_vectors
from diagnostics.signatures import OBSERVABLES
from sim.cycle import phase_params
from sim.rigs import Condition, Rig, reference_rig
from tests.diagnostics.test_any_rig import rig_with


def _stall_load(rig: Rig) -> float:
    """Load [N] the relief setting can just hold on the cap side (paper 002 eq. 6)."""
    return rig.base["relief.Pset"] * rig.values()["cylinder.A1"]


def _compare(rig: Rig, cond: Condition) -> tuple[FastMaps, int]:
    with_chord, damped = FastMaps(rig, cond), FastMaps(rig, cond, chord=False)
    np.testing.assert_allclose(with_chord.nominal, damped.nominal, rtol=1e-8)
    masked = 0
    for name, hm in damped.maps.items():
        got = with_chord.maps[name].pred
        # the same points have no prediction
        np.testing.assert_array_equal(np.isnan(got), np.isnan(hm.pred), err_msg=name)
        masked += int(np.isnan(hm.pred).sum())
        scale = np.nanmax(np.abs(hm.pred), axis=0)
        err = np.abs(got - hm.pred) / np.where(scale > 0, scale, 1.0)
        assert float(np.nanmax(err)) < 1e-8, name
    return with_chord, masked


@pytest.mark.parametrize("fraction", [0.3, 0.9, 0.97, 1.05])
def test_chord_maps_equal_the_damped_maps_up_to_the_stall_ridge(fraction: float) -> None:
    rig = reference_rig()
    cond = Condition(load=fraction * _stall_load(rig), oil_temperature=47.0)
    maps, _ = _compare(rig, cond)
    c = maps.ctx.counts
    # most solves are the chord's (one evaluation an iteration), few fall back
    assert c[0] > 3 * c[5], c
    iw = OBSERVABLES.index("speed_work")
    # no stroke runs backwards: a piston the load overcomes sits on its end stop (speed 0)
    assert all(np.nanmin(h.pred[:, iw]) >= 0.0 for h in maps.maps.values())
    if 0.5 < fraction < 1.0:
        # the stall ridge is inside the maps (some fault stops the working stroke on its
        # end stop): the comparison covers it
        assert any(np.nanmin(h.pred[:, iw]) == 0.0 < np.nanmax(h.pred[:, iw])
                   for h in maps.maps.values())


def test_chord_maps_on_a_hot_differential_rig() -> None:
    rig = rig_with(0.06, 0.0, 0.03, Lc=0.003)
    _, masked = _compare(rig, Condition(load=1000.0, oil_temperature=70.0))
    assert masked > 0


def test_phase_vectors_are_the_cycles() -> None:
    rig = reference_rig()
    rng = np.random.default_rng(4)
    for _ in range(20):
        cond = Condition(load=float(rng.uniform(0.0, 3e4)),
                         oil_temperature=float(rng.uniform(15.0, 70.0)),
                         back_pressure=float(rng.uniform(0.0, 3e5)))
        want = np.array([phase_params(rig, ph, None, cond) for ph in ("working", "return")])
        np.testing.assert_array_equal(phase_vectors(rig, cond), want)
