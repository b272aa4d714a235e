"""Signature maps agree with direct steady solves."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.hypotheses import WORN
from diagnostics.signatures import SignatureMaps
from sim.rigs import Condition, reference_rig


@pytest.mark.parametrize("load", [2.1e3, 6.3e3])
def test_maps_interpolate_the_model_within_4e_4(load):
    rig = reference_rig()
    maps = SignatureMaps(rig, Condition(load=load))
    for name, hm in maps.maps.items():
        (p,) = hm.params
        for i in range(5, hm.axes[0].size, 13):
            direct = maps.predict(hm.params, np.array([p.from_z(hm.axes[0][i])]))
            if direct[6] < 0.3 * maps.nominal[6]:
                continue  # piston nearly stalled: not a state a diagnosis fits
            assert np.all(np.abs(hm.pred[i] - direct) <= 4e-4 * np.abs(direct)), (name, i)
    # a single fault blames a worn component: its axis starts at the 'none' severity limit
    (p,) = maps.maps["cylinder"].params
    start = p.from_z(float(maps.maps["cylinder"].axes[0][0]))
    assert start == pytest.approx(WORN["cc"] * rig.base["cylinder.cc"], rel=1e-9)
    direct = maps.predict(maps.maps["cylinder"].params, np.array([start]))
    assert np.allclose(maps.maps["cylinder"].pred[0], direct, rtol=1e-9)
