"""The analysis grid rests on measured samples (diagnostics/discrepancy/signals.py).

A logger dropout resampled straight across made "structure" in the balances: healthy
records with 0.5 s missing read "unexplained" (a discrepancy pass).  The samples of the
1 kHz grid inside a gap, and within half the Savitzky-Golay window of it, are marked
unmeasured; every balance leaves them out, and hose B's windowed integrals leave out every
window that reaches into the gap.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from diagnostics.discrepancy.balances import balance_data
from diagnostics.discrepancy.signals import HOSE_WINDOW, prepare
from diagnostics.discrepancy.synthetic import CHANNELS, synthesize
from diagnostics.sampling import gap_spans
from diagnostics.timeseries import SeriesRecord
from sim.rigs import reference_rig
from sim.rigs.assembly import Condition

T0, T1 = 1.0, 1.5
WINDOW = 0.041


def _records() -> tuple[list[SeriesRecord], list[SeriesRecord]]:
    rig = reference_rig()
    rng = np.random.default_rng(3)
    # with valve port B's pressure: hose B's balance too
    whole = [synthesize(rig, Condition(load=f, oil_temperature=40.0), rng=rng, name=f"r{i}",
                        channels=(*CHANNELS, "P_valve_B"))
             for i, f in enumerate((2100.0, 4200.0))]
    holed = []
    for r in whole:
        keep = (r.t <= T0) | (r.t >= T1)
        holed.append(dataclasses.replace(
            r, t=r.t[keep], channels={k: v[keep] for k, v in r.channels.items()},
            phase=None if r.phase is None else r.phase[keep]))
    return whole, holed


def test_the_grid_across_a_gap_and_its_margin_is_left_out() -> None:
    whole, holed = _records()
    rig = reference_rig()
    assert gap_spans(holed[0]) == [(T0, T1)] and gap_spans(whole[0]) == []
    s = prepare(holed, rig, window=WINDOW)
    measured = s.values["measured"] > 0.5
    t = s.t
    margin = (round(WINDOW * 1000) // 2) / 1000.0
    inside = (t > T0 - margin) & (t < T1 + margin)
    assert not measured[inside].any()
    assert measured[~inside].all()
    # ~0.54 s of each record: the gap and a half window at each end
    assert abs(inside.sum() / len(holed) - (T1 - T0 + 2 * margin) * 1000) <= 2
    # the whole records keep every sample
    assert (prepare(whole, rig, window=WINDOW).values["measured"] > 0.5).all()
    for d in balance_data(s, rig.values()):
        kept_t = t[d.mask]
        assert not ((kept_t > T0 - margin) & (kept_t < T1 + margin)).any(), d.balance.name
    # hose B's integrals: no window that reaches into the gap
    ok = s.values["hose.ok"] > 0.5
    assert ok.any()
    assert "hose_pressure" in [d.balance.name for d in balance_data(s, rig.values())]
    reach = (t > T0 - margin) & (t < T1 + margin + HOSE_WINDOW)
    assert not ok[reach].any()
