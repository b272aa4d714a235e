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


#: a strength of each pump-outlet entry that takes 1-10 % of the working flow [SI]
PUMP_EFFECTS = {"turbulent_pump_slip": ("K_t", 5e-10), "pump_clearance_pressure": ("k_c", 3e-22),
                "speed_offset": ("d_speed", -5.0), "pump_compressibility_loss": ("k_b", 2e-9),
                "viscous_pump_slip": ("C_s", 1e-8), "pump_filling": ("k_f", 2e-4)}


def test_the_pump_entries_of_the_library_apply_to_this_circuit_and_leave_their_signature(
        ) -> None:
    """The library's pump-outlet entries touch only ``pump.*`` and ``fluid.*``, so a rig of
    this circuit can hold them (what ``hydrodiag discover`` stores for the ZeMA rig): at
    zero strength the rig is the base exactly; with a strength, the pump-outlet volume
    balance at the steady state leaves exactly the entry's regressor times its strength —
    the column the discrepancy workflow fits."""
    from sim.components.effects import effects_for, get_effect
    from sim.rigs import load_rig_document

    assert set(effects_for("pump-relief-orifice")) == set(PUMP_EFFECTS)
    base = _steady()
    for name, (pname, value) in PUMP_EFFECTS.items():
        effect = get_effect(name, "pump-relief-orifice")
        unit = effect.parameter(pname).unit
        doc = load_rig_document(RIG)
        doc["effects"] = {name: {"parameters": {pname: {"value": 0.0, "unit": unit}}}}
        rig = load_rig(doc)
        m = rig.model
        p = rig.params()
        y = m.steady(m.initial_state(p), p)
        off = dict(zip(m.output_names, map(float, m.outputs(np.zeros(1), y[None, :], p)[0]),
                       strict=True))
        assert all(off[k] == base[k] for k in base), name
        doc["effects"][name]["parameters"][pname]["value"] = value
        rig = load_rig(doc)
        m, p, v = rig.model, rig.params(), rig.values()
        y = m.steady(m.initial_state(p), p)
        on = dict(zip(m.output_names, map(float, m.outputs(np.zeros(1), y[None, :], p)[0]),
                      strict=True))
        # the pump-outlet balance with the base pump's own leak P/Rlp: what is left is the
        # effect's flow (a leak path also counts in Q_pump_leak, the others do not)
        own_leak = on["P_pump"] / v["pump.Rlp"]
        unexplained = (v["pump.speed"] * v["pump.Vp"] - on["Q_work"] - own_leak
                       - on["Q_relief"])
        leaks = name in ("turbulent_pump_slip", "pump_clearance_pressure", "viscous_pump_slip")
        assert on["Q_pump_leak"] - own_leak == pytest.approx(
            unexplained if leaks else 0.0, rel=1e-6, abs=1e-15), name
        signals = {"P_pump": np.array([on["P_pump"]]), "Vp": np.array([v["pump.Vp"]]),
                   "speed": np.array([v["pump.speed"]]), "mu": np.array([v["fluid.mu"]])}
        expected = value * float(effect.entry.regressor(signals)[0])
        assert 0.01 < abs(expected) / on["Q_work"] < 0.1, name
        assert unexplained == pytest.approx(expected, rel=1e-3), name


def test_an_effect_on_the_cylinder_is_refused_on_this_circuit_naming_where_it_applies() -> None:
    from sim.components.effects import get_effect
    from sim.errors import RigFileError
    from sim.rigs import load_rig_document

    doc = load_rig_document(RIG)
    doc["effects"] = {"couette_drag": {}}
    with pytest.raises(RigFileError, match="applies to circuit 'pump-valve-cylinder', not "
                                           "'pump-relief-orifice'") as err:
        load_rig(doc)
    assert err.value.field is not None and err.value.field.startswith("effects")
    assert get_effect("viscous_pump_slip", "pump-relief-orifice").entry.applies_to(
        "pump-valve-cylinder")
