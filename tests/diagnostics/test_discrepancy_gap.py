"""The held-out gap's timing floor (:func:`diagnostics.discrepancy.gap.gap_table`): a logged
switch is placed to within a sample, and the pressures ring after it, so the model's own
noise-free cycle shows an "after step" gap that the floor accounts for."""

from __future__ import annotations

import numpy as np

from diagnostics.discrepancy.gap import gap_table
from diagnostics.discrepancy.simulate import simulate_record
from diagnostics.discrepancy.synthetic import NOISE, synthesize
from sim.rigs import reference_rig
from sim.rigs.assembly import Condition


def test_the_models_own_cycle_has_its_after_step_gap_within_the_timing_floor() -> None:
    rig = reference_rig()
    rec = synthesize(rig, Condition(load=4200.0, oil_temperature=50.0),
                     rng=np.random.default_rng(0), name="own",
                     sigma=dict.fromkeys(NOISE, 0.0))
    rows = {(r.channel, r.region): r
            for r in gap_table(rec, simulate_record(rig, rec), ["P1", "P2", "v"])}
    for c in ("P1", "P2", "v"):
        step, steady = rows[c, "after step"], rows[c, "steady"]
        assert step.timing_floor > 0.0
        # the same model: what is left after a step is the switch's placement
        assert step.rmse <= 3.0 * step.timing_floor + 1e-12, (c, step)
        # in steady motion half a sample moves nothing that matters
        assert steady.timing_floor < 0.1 * step.timing_floor
