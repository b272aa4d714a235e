"""The effect library: each element's balances, its law, and 'zero strength = base rig'."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sim.bondgraph.elements import Kind
from sim.components.effects import EFFECTS, effects_for, get_effect, parameter_bounds
from sim.cycle import run_cycle
from sim.errors import ParameterError, RigFileError
from sim.rigs import load_rig, reference_rig, reference_rig_document
from sim.rigs.schema import validate_rig_document
from sim.steady import steady_phase

#: a clearly non-zero, plausible strength per effect [SI]
STRENGTHS = {
    "stribeck_friction": ("F_s", 300.0),
    "seal_friction_pressure": ("k_p", 2e-5),
    "couette_drag": ("k_c", 2e4),
    "turbulent_piston_leakage": ("K_t", 1e-8),
    "piston_clearance_pressure": ("k_c", 5e-19),
    "turbulent_spool_leakage": ("K_t", 5e-9),
    "turbulent_pump_slip": ("K_t", 5e-9),
    "pump_clearance_pressure": ("k_c", 5e-19),
    "speed_offset": ("d_speed", 5.0),
    "pump_compressibility_loss": ("k_b", 6.7e-10),
    "viscous_pump_slip": ("C_s", 1e-8),
    "pump_filling": ("k_f", 1e-4),
    "viscosity_law": ("lam", 0.01),
    "relief_override": ("k_ov", 4e12),
    "entrained_air": ("alpha", 1e-3),
    "line_unsteady_friction": ("k3", 0.05),
    "load_scale": ("k_F", 0.05),
}


def _doc(effects: dict[str, float | None]) -> dict:
    doc = reference_rig_document()
    doc["effects"] = {}
    for name, value in effects.items():
        pname, unit = STRENGTHS[name][0], get_effect(name).parameter(STRENGTHS[name][0]).unit
        body = {} if value is None else {"parameters": {pname: {"value": value, "unit": unit}}}
        doc["effects"][name] = body
    return doc


@pytest.fixture(scope="module")
def full_rig():
    return load_rig(_doc({n: v for n, (_, v) in STRENGTHS.items()}))


def test_library_covers_the_issue_minimum():
    rig_effects = effects_for("pump-valve-cylinder")
    balances = [e.entry.balance for e in rig_effects.values()]
    assert set(STRENGTHS) == set(rig_effects)
    assert sum(b in ("piston_force", "chamber_flow", "valve_flow") for b in balances) >= 4
    assert sum(b == "pump_flow" for b in balances) >= 3
    for e in EFFECTS.values():
        assert e.entry.explanation and e.entry.reference and e.entry.signature
        strength = e.parameter(e.entry.coefficient)
        assert strength is not None and strength.default == 0.0


def test_junction_balances_and_effect_dissipation_at_random_states(full_rig):
    m = full_rig.model
    g = m.system.graph
    rng = np.random.default_rng(3)
    p = full_rig.params(graph_values={"valve.N": 1.0})
    effect_rs = [el for el in g.elements.values()
                 if el.kind is Kind.R and el.name.split(".")[0] in EFFECTS]
    # every effect but the speed offset, the stated load and the filling loss (sources) is
    # an R
    assert len(effect_rs) == 10
    for _ in range(25):
        y = m.initial_state(p)
        for i in range(len(m.state_names)):
            y[i] = rng.uniform(0, 5e6) if m.scale[i] == 1e5 else rng.normal() * 1e3 * m.scale[i]
        y[m.state_index("cylinder.x")] = rng.uniform(0, 0.5)
        e, f = m.bond_values(y, p)
        for el in g.elements.values():
            bonds = g.bonds_of(el.name)
            s = np.array([b.sign_at(el.name) for b in bonds], dtype=float)
            idx = [b.index for b in bonds]
            if el.kind is Kind.ZERO:
                assert abs(s @ f[idx]) <= 1e-12 * np.abs(f[idx]).max() + 1e-20, el.name
            elif el.kind is Kind.ONE:
                assert abs(s @ e[idx]) <= 1e-12 * np.abs(e[idx]).max() + 1e-9, el.name
        for el in effect_rs:
            (b,) = g.bonds_of(el.name)
            # power into every effect resistance is ≥ 0: it only dissipates
            assert b.sign_at(el.name) * e[b.index] * f[b.index] >= -1e-9, el.name


def test_effect_laws_match_hand_calculations_at_a_state(full_rig):
    m = full_rig.model
    g = m.system.graph
    p = full_rig.params(graph_values={"valve.N": 1.0})
    y = m.initial_state(p)
    P1, P2, v = 6.0e6, 1.5e6, 0.05
    for name, value in (("cylinder.C1", P1), ("cylinder.C2", P2), ("cylinder.mass", v)):
        y[m.state_names.index(name)] = value
    y[m.state_index("cylinder.x")] = 0.2
    e, f = m.bond_values(y, p)
    vals = full_rig.values()
    mu = vals["fluid.mu"]

    def port(el: str) -> tuple[float, float]:
        (b,) = g.bonds_of(el)
        return e[b.index], f[b.index]

    assert port("stribeck_friction.R")[0] == pytest.approx(
        300.0 * math.exp(-(v / 0.02) ** 2) * math.tanh(v / vals["cylinder.v_s"]), rel=1e-12)
    assert port("seal_friction_pressure.R")[0] == pytest.approx(2e-5 * (P1 + P2), rel=1e-9)
    assert port("couette_drag.R")[0] == pytest.approx(2e4 * mu * v, rel=1e-12)
    # the stated-load error: a source of −k_F·F_load, the sign of SeF_load (eq. 38)
    assert port("load_scale.Se")[0] == pytest.approx(-0.05 * vals["load.force"], rel=1e-12)
    assert port("load.F")[0] == pytest.approx(-vals["load.force"], rel=1e-12)
    dp = P1 - P2
    assert port("turbulent_piston_leakage.R")[1] == pytest.approx(
        1e-8 * dp / (dp * dp + 1e8) ** 0.25, rel=1e-12)
    assert port("piston_clearance_pressure.R")[1] == pytest.approx(5e-19 * dp * dp / mu,
                                                                    rel=1e-12)


def test_leakage_outputs_count_the_leak_paths_effects_add(full_rig):
    # a worn piston leaking through an orifice beside its gap leaks the sum: Q_cyl_leak
    # read the laminar gap alone, so a diagnosis comparing a measured leakage with it (and
    # /simulate's table) missed the effect's flow
    m = full_rig.model
    g = m.system.graph
    p = full_rig.params(graph_values={"valve.N": 1.0})
    y = m.initial_state(p)
    for name, value in (("cylinder.C1", 6.0e6), ("cylinder.C2", 1.5e6),
                        ("cylinder.mass", 0.05), ("pump.Cp", 7.0e6)):
        y[m.state_names.index(name)] = value
    y[m.state_index("cylinder.x")] = 0.2
    _, f = m.bond_values(y, p)
    out = dict(zip(m.output_names, m.outputs(np.zeros(1), y[None, :], p)[0], strict=True))

    def flow(el: str) -> float:
        (b,) = g.bonds_of(el)
        return float(f[b.index])

    paths = {"Q_cyl_leak": ["turbulent_piston_leakage.R", "piston_clearance_pressure.R"],
             "Q_valve_leak": ["turbulent_spool_leakage.R"],
             "Q_pump_leak": ["turbulent_pump_slip.R", "pump_clearance_pressure.R",
                             "viscous_pump_slip.R"]}
    base = {"Q_cyl_leak": flow("cylinder.Rlc"), "Q_valve_leak": flow("valve.Rlv"),
            "Q_pump_leak": flow("pump.leak")}
    for output, rs in paths.items():
        added = [flow(r) for r in rs]
        assert all(q > 0 for q in added), output  # each path leaks at this state
        assert out[output] == pytest.approx(base[output] + sum(added), rel=1e-12), output
    # and the base rig's outputs stay its own elements' flows
    plain = reference_rig()
    pm = plain.model
    pp = plain.params(graph_values={"valve.N": 1.0})
    y0 = pm.initial_state(pp)
    (b,) = pm.system.graph.bonds_of("cylinder.Rlc")
    _, f0 = pm.bond_values(y0, pp)
    q0 = dict(zip(pm.output_names, pm.outputs(np.zeros(1), y0[None, :], pp)[0], strict=True))
    assert q0["Q_cyl_leak"] == f0[b.index]


def test_zero_strength_gives_the_base_rig_exactly():
    base = run_cycle(reference_rig(), rtol=1e-3).timeseries
    zero = run_cycle(load_rig(_doc({n: None for n in STRENGTHS})), rtol=1e-3).timeseries
    assert base is not None and zero is not None
    assert list(zero.columns) == list(base.columns)
    np.testing.assert_array_equal(zero.iloc[:, 2:].to_numpy(), base.iloc[:, 2:].to_numpy())


def test_seal_friction_raises_the_working_pressure_by_the_hand_computed_force():
    rig = load_rig(_doc({"seal_friction_pressure": 2e-5}))
    base = steady_phase(reference_rig(), "working").outputs
    out = steady_phase(rig, "working").outputs
    # force balance at the piston: A1·ΔP1 − A2·ΔP2 = k_p·(P1 + P2) at the new point
    a1 = rig.values()["cylinder.A1"]
    extra = a1 * ((out["P1"] - base["P1"]) - (out["P2"] - base["P2"]))
    assert extra == pytest.approx(2e-5 * (out["P1"] + out["P2"]), rel=0.02)


def test_load_scale_raises_the_working_pressure_by_k_times_the_stated_load_only():
    rig = load_rig(_doc({"load_scale": 0.03}))
    v = rig.values()
    for phase, extra_force in (("working", 0.03 * v["load.force"]), ("return", 0.0)):
        base = steady_phase(reference_rig(), phase).outputs
        out = steady_phase(rig, phase).outputs
        # force balance at the piston: A1·ΔP1 − A2·ΔP2 = k_F·F_load (zero in the return
        # stroke, where paper 002 eq. 52 sets the load to zero); the speed, and with it the
        # viscous friction Kf·ẋ, moves by the extra leak at the higher pressure (< 0.1 %)
        extra = v["cylinder.A1"] * (out["P1"] - base["P1"]) - v["cylinder.A2"] * (
            out["P2"] - base["P2"])
        assert extra == pytest.approx(extra_force, rel=2e-3, abs=1e-9)


def test_speed_offset_adds_vp_times_domega_to_the_delivered_flow():
    rig = load_rig(_doc({"speed_offset": 5.0}))
    base = steady_phase(reference_rig(), "working").outputs
    out = steady_phase(rig, "working").outputs
    vp = rig.values()["pump.Vp"]
    assert out["Q_meter_B"] - base["Q_meter_B"] == pytest.approx(vp * 5.0, rel=0.02)


def test_compressibility_loss_takes_k_b_p_vp_omega_from_the_delivered_flow():
    rig = load_rig(_doc({"pump_compressibility_loss": 6.7e-10}))
    base = steady_phase(reference_rig(), "working").outputs
    out = steady_phase(rig, "working").outputs
    v = rig.values()
    # the flow lost at the outlet junction is k_b·P·Vp·ω at the new pressure (≈ 0.3 % at
    # 4 MPa: β_c = 1.5 GPa); Q_meter_B is what reaches the valve
    lost = 6.7e-10 * out["P_pump"] * v["pump.Vp"] * v["pump.speed"]
    assert base["Q_meter_B"] - out["Q_meter_B"] == pytest.approx(lost, rel=0.03)


def test_viscous_pump_slip_takes_c_s_p_vp_over_mu_from_the_delivered_flow():
    """Paper 000 eq. 4 by hand: C_s·P·Vp/μ(T) leaves the outlet junction, and it doubles
    between 40 °C and the oil temperature where μ has halved."""
    rig = load_rig(_doc({"viscous_pump_slip": 1e-8}))
    lost = {}
    for theta in (40.0, 60.0):
        cond = replace(rig.default_condition(), oil_temperature=theta)
        base = steady_phase(reference_rig(), "working", condition=cond).outputs
        out = steady_phase(rig, "working", condition=cond).outputs
        v = rig.values(condition=cond)
        lost[theta] = (1e-8 * out["P_pump"] * v["pump.Vp"] / v["fluid.mu"], v["fluid.mu"])
        assert base["Q_meter_B"] - out["Q_meter_B"] == pytest.approx(lost[theta][0], rel=0.03)
    ratio = lost[60.0][0] / lost[40.0][0]
    assert ratio > 1.8
    assert ratio == pytest.approx(lost[40.0][1] / lost[60.0][1], rel=0.05)


def test_pump_filling_draws_k_f_vp_omega_squared_from_the_outlet_junction():
    """At the steady working point the filling loss's source carries exactly k_f·Vp·ω² out
    of the pump-outlet 0-junction, at each shaft speed (the flow of the shaft bond), and the
    junction balances: ω·Vp = P/Rlp + Q_f + Q_B (Ṗ = 0, the relief closed)."""
    from sim.cycle import phase_params

    k_f = 1e-4
    rig = load_rig(_doc({"pump_filling": k_f}))
    m = rig.model
    g = m.system.graph
    lost = {}
    for frac in (0.8, 1.0):
        cond = replace(rig.default_condition(),
                       pump_speed=frac * reference_rig().values()["pump.speed"])
        point = steady_phase(rig, "working", condition=cond)
        v = rig.values(condition=cond)
        p = phase_params(rig, "working", None, cond)
        _, f = m.bond_values(point.state, p)
        (b,) = g.bonds_of("pump_filling.MSf")
        omega = v["pump.speed"]
        q_f = -b.sign_at("pump.out") * f[b.index]   # flow out of the junction
        assert q_f == pytest.approx(k_f * v["pump.Vp"] * omega ** 2, rel=1e-12)
        out = point.outputs
        assert out["Q_relief"] == pytest.approx(0.0, abs=1e-12)
        assert omega * v["pump.Vp"] == pytest.approx(
            out["P_pump"] / v["pump.Rlp"] + q_f + out["Q_meter_B"], rel=1e-9)
        # every bond of the outlet junction: the flows sum to zero
        bonds = g.bonds_of("pump.out")
        signs = np.array([x.sign_at("pump.out") for x in bonds], dtype=float)
        flows = f[[x.index for x in bonds]]
        assert abs(signs @ flows) <= 1e-12 * np.abs(flows).max()
        # the loss is no leak to a drain line: Q_pump_leak stays the pump's own P/Rlp
        assert out["Q_pump_leak"] == pytest.approx(out["P_pump"] / v["pump.Rlp"], rel=1e-9)
        base = steady_phase(reference_rig(), "working", condition=cond).outputs
        assert base["Q_meter_B"] - out["Q_meter_B"] == pytest.approx(q_f, rel=0.01)
        lost[frac] = q_f
    # ∝ ω²: 0.8² of the full-speed loss at 80 % speed
    assert lost[0.8] / lost[1.0] == pytest.approx(0.64, rel=1e-9)


def test_effects_section_errors_name_the_field():
    doc = reference_rig_document()
    doc["effects"] = {"magic_friction": {}}
    with pytest.raises(RigFileError) as exc:
        validate_rig_document(doc)
    assert exc.value.field == "effects.magic_friction"
    doc["effects"] = {"couette_drag": {"parameters": {"k_c": {"value": 1.0, "unit": "N"}}}}
    with pytest.raises(RigFileError) as exc:
        validate_rig_document(doc)
    assert exc.value.field == "effects.couette_drag.parameters.k_c.unit"
    doc["effects"] = {"couette_drag": {"parameters": {"k_c": {"value": -1.0, "unit": "m"}}}}
    with pytest.raises(RigFileError) as exc:
        validate_rig_document(doc)
    assert exc.value.field == "effects.couette_drag.parameters.k_c"
    doc["effects"] = {"couette_drag": {"params": {}}}
    with pytest.raises(RigFileError) as exc:
        validate_rig_document(doc)
    assert exc.value.field == "effects.couette_drag.params"


def test_effect_parameters_take_overrides_and_the_model_is_cached_per_effect_set():
    a = load_rig(_doc({"couette_drag": None}))
    b = load_rig(_doc({"couette_drag": 1e3}))
    assert a.model is b.model
    assert a.model is not reference_rig().model
    assert a.values({"couette_drag.k_c": 7.0})["couette_drag.k_c"] == 7.0
    with pytest.raises(ParameterError):
        a.values({"couette_drag.k_c": -1.0})
    with pytest.raises(ParameterError):
        reference_rig().values({"couette_drag.k_c": 7.0})


def test_parameter_bounds_are_the_declared_ones() -> None:
    keys = [f"{name}.{p.name}" for name, e in EFFECTS.items() for p in e.parameters]
    lo, hi = parameter_bounds(keys)
    for key, low, high in zip(keys, lo, hi, strict=True):
        name, _, pname = key.partition(".")
        decl = EFFECTS[name].parameter(pname)
        assert decl is not None
        assert low == (-np.inf if decl.lower is None else decl.lower)
        assert high == (np.inf if decl.upper is None else decl.upper)
    with pytest.raises(RigFileError, match="no parameter"):
        parameter_bounds(["viscosity_law.not_a_parameter"])
