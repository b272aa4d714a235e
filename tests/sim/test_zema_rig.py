"""The ZeMA rig file (circuit pump-relief-orifice) against the rig's measured plateaus."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim.rigs import load_rig

RIG = Path(__file__).resolve().parents[2] / "sim" / "rigs" / "zema.yaml"


def _steady(overrides: dict[str, float] | None = None) -> dict[str, float]:
    rig = load_rig(RIG)
    m = rig.model
    p = rig.params(overrides)
    y = m.steady(m.initial_state(p), p)
    return dict(zip(m.output_names, map(float, m.outputs(np.zeros(1), y[None, :], p)[0]),
                    strict=True))


def test_every_parameter_states_its_source() -> None:
    rig = load_rig(RIG)
    assert rig.circuit.name == "pump-relief-orifice"
    assert set(rig.spec.components) == {"pump", "relief", "work"}
    for _ctype, params in rig.spec.components.values():
        for q in params.values():
            assert q.source.strip()


def test_working_plateau_and_relief_plateau_match_the_measured_cycle() -> None:
    work = _steady()
    # healthy plateau of SOURCE.md: FS1 7.93 l/min at PS1 146.7 bar
    assert work["Q_work"] * 6e4 == pytest.approx(7.93, rel=0.01)
    assert work["P_pump"] / 1e5 == pytest.approx(146.7, rel=0.04)
    # volume balance at the pump outlet: geometric flow = leakage + relief + working flow
    geometric = 5.45e-6 * 1500.0 / 60.0
    assert work["Q_pump_leak"] + work["Q_relief"] + work["Q_work"] == pytest.approx(geometric,
                                                                                   rel=1e-9)
    # working circuit shut (seconds 1-8 of a cycle): the relief valve holds about 191 bar
    shut = _steady({"work.Kt": 1e-12})
    assert shut["P_pump"] / 1e5 == pytest.approx(191.0, abs=1.5)
    assert shut["Q_work"] < 1e-3 * geometric


def test_more_internal_leakage_lowers_the_working_flow() -> None:
    healthy, leaky = _steady(), _steady({"pump.Rlp": 3.5e12 / 3})
    assert leaky["Q_work"] < healthy["Q_work"]
    assert leaky["Q_pump_leak"] == pytest.approx(leaky["P_pump"] / (3.5e12 / 3), rel=1e-9)
    assert math.isfinite(leaky["T_pump"])
