"""Which new library entries the paper-002 test design can tell apart (3 cycles at
2.1/4.2/6.3 kN and 40/50/60 °C, one pump speed)."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.discrepancy.balances import balance_data
from diagnostics.discrepancy.selection import select
from diagnostics.discrepancy.signals import prepare
from diagnostics.discrepancy.synthetic import synthesize
from sim.rigs import load_rig, reference_rig, reference_rig_document
from sim.rigs.assembly import Condition

CONDITIONS = ((2100.0, 40.0), (4200.0, 50.0), (6300.0, 60.0))


def test_pump_compressibility_loss_is_the_laminar_leak_column_at_one_speed():
    doc = reference_rig_document()
    doc["effects"] = {"pump_compressibility_loss": {"parameters": {
        "k_b": {"value": 6.7e-10, "unit": "1/Pa"}}}}
    rig = load_rig(doc)
    rng = np.random.default_rng(3)
    recs = [synthesize(rig, Condition(load=L, oil_temperature=T), rng=rng, name=f"L{L:.0f}")
            for L, T in CONDITIONS]
    data = {d.balance.name: d for d in balance_data(prepare(recs, reference_rig()),
                                                    reference_rig().values())}
    pump = data["pump_flow"]
    col = pump.candidates["pump_compressibility_loss"]
    # P·ω·Vp at one speed is the laminar leak's column P scaled: correlation 1
    assert abs(np.corrcoef(col, pump.base["pump.Rlp"])[0, 1]) > 1 - 1e-12
    sel = select(pump, bootstrap=0)
    assert ["base", "pump_compressibility_loss"] in sel.ambiguity
    assert sel.detectable["pump_compressibility_loss"] == float("inf")
    # the hidden loss is absorbed by the re-fitted leak: 1/Rlp grows by k_b·ω·Vp
    v = reference_rig().values()
    g = sel.base_coefficients["pump.Rlp"]
    assert g - 1 / v["pump.Rlp"] == pytest.approx(
        6.7e-10 * v["pump.speed"] * v["pump.Vp"], rel=0.1)



def test_viscous_pump_slip_is_the_laminar_leak_column_at_one_temperature():
    """P·Vp/μ at one oil temperature is the laminar leak's column P scaled: the selection
    puts it in the base's ambiguity group; over 40/50/60 °C it is a column of its own."""
    doc = reference_rig_document()
    doc["effects"] = {"viscous_pump_slip": {"parameters": {"C_s": {"value": 1e-8, "unit": "1"}}}}
    rig = load_rig(doc)
    for conditions, apart in ((tuple((L, 50.0) for L, _ in CONDITIONS), False),
                              (CONDITIONS, True)):
        rng = np.random.default_rng(3)
        recs = [synthesize(rig, Condition(load=L, oil_temperature=T), rng=rng,
                           name=f"L{L:.0f}") for L, T in conditions]
        data = {d.balance.name: d for d in balance_data(prepare(recs, reference_rig()),
                                                        reference_rig().values())}
        pump = data["pump_flow"]
        r = abs(np.corrcoef(pump.candidates["viscous_pump_slip"], pump.base["pump.Rlp"])[0, 1])
        sel = select(pump, bootstrap=0)
        if apart:
            assert r < 0.999
            assert ["base", "viscous_pump_slip"] not in sel.ambiguity
        else:
            assert r > 1 - 1e-12
            assert ["base", "viscous_pump_slip"] in sel.ambiguity
