"""Signature maps agree with direct steady solves."""

from __future__ import annotations

import numpy as np
import pytest

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
    assert np.allclose(maps.maps["cylinder"].pred[0], maps.nominal, rtol=1e-9)
