"""The fast maps locate the ridges between moving, creeping and held strokes from the
piston's drive (diagnostics.fastpath.ridges): each bracket holds a change of stroke state
of the direct solves and is narrow, and the maps follow direct solves across the ridges
to 5e-4 of each reading's range, or as closely as the direct maps do."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.fastpath.maps import FastMaps
from diagnostics.fastpath.ridges import RIDGE_TOL, Piece, locate
from diagnostics.signatures import SignatureMaps
from diagnostics.stroke_state import creep_speed, stroke_codes
from sim.rigs import Condition, reference_rig


@pytest.mark.parametrize(("load", "temp"), [(4200.0, 55.0), (6500.0, 30.0), (8600.0, 25.0)])
def test_ridges_bracket_the_direct_state_change_and_the_maps_follow_direct_solves(
        load: float, temp: float) -> None:
    rig = reference_rig()
    cond = Condition(load=load, oil_temperature=temp)
    fast, direct = FastMaps(rig, cond), SignatureMaps(rig, cond)
    creep = creep_speed(rig)
    crossed = 0
    for name in ("cylinder", "valve"):
        hm = fast.maps[name]
        (p,) = hm.params
        z = hm.axes[0]
        truth = np.array([direct.predict((p,), np.array([p.from_z(float(v))])) for v in z])
        codes = stroke_codes(truth, creep)
        if not ((codes[1:] != codes[:-1]) & (codes[1:] >= 0) & (codes[:-1] >= 0)).any():
            continue
        crossed += 1
        # the brackets: the fast maps' own ridge location on this axis
        out, ok, ys, drv = fast.ctx.probe(fast._grid([p] * z.size, z),
                                          np.ones(z.size, dtype=np.int64))
        out = fast._retried(p, z, out, ok.copy())  # as the maps: the direct evaluator
        cuts = locate(fast, [Piece(p, z, out, ys, drv, ok)])[0]
        assert cuts
        for cut in cuts:
            ends = np.array([direct.predict((p,), np.array([p.from_z(v)]))
                             for v in (cut.lo, cut.hi)])
            a, b = stroke_codes(ends, creep)
            assert a != b, (name, cut)
            # the nodes here are the fine axis, ten times closer than the maps' coarse
            # ones: a bracket within four of its tolerances is still narrower than theirs
            assert 0.0 < cut.hi - cut.lo <= 4.0 * RIDGE_TOL * (z[1] - z[0])
        # to 5e-4 of each reading's range, or as close as the direct maps' own
        # interpolation (bracketed their way) comes, within a quarter
        span = np.nanmax(truth, axis=0) - np.nanmin(truth, axis=0)
        errs = []
        for pred in (hm.pred, direct.maps[name].pred):
            ok_t = np.isfinite(truth) & np.isfinite(pred)
            err = np.abs(pred - truth) / np.where(span > 0, span, 1.0)
            errs.append(float(np.max(err[ok_t])))
        assert errs[0] <= max(5e-4, 1.25 * errs[1]), (name, errs)
    assert crossed >= 1
