"""Bond-graph engine: causality, equations, compiled model, junction laws, export."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sim.bondgraph import (
    GY,
    TF,
    BondGraph,
    C,
    I,
    One,
    R,
    Se,
    Sf,
    Zero,
    call,
    compile_graph,
    derive_equations,
    to_dot,
    to_json,
)
from sim.bondgraph.elements import Kind
from sim.bondgraph.laws import constant, linear_effort, linear_flow, quotient
from sim.errors import (
    AlgebraicLoopError,
    CausalityError,
    DerivativeCausalityError,
    ModelStructureError,
)


def _lin_r(name: str, param: str) -> R:
    return R(name, flow=call(linear_flow, "e", f"p:{param}"),
             effort=call(linear_effort, "f", f"p:{param}"))


def motor_load_graph() -> BondGraph:
    """DC motor (GY) driving a gearbox (TF) and an inertia with a spring: every kind."""
    g = BondGraph("motor")
    for name, val in (("U", 12.0), ("Ra", 0.5), ("La", 1e-3), ("km", 0.05), ("ratio", 0.1),
                      ("J", 1e-4), ("b", 1e-3), ("k", 2.0), ("Jl", 5e-3)):
        g.parameter(name, val)
    g.add(Se("U", constant, "p:U"))
    g.add(One("1i"))
    g.add(_lin_r("Ra", "Ra"))
    g.add(I("La", constant, "p:La", scale=1.0))
    g.add(GY("km", constant, "p:km"))
    g.add(One("1w"))
    g.add(I("J", constant, "p:J", scale=10.0))
    g.add(_lin_r("b", "b"))
    g.add(TF("gear", constant, "p:ratio"))
    g.add(Zero("0s"))
    g.add(C("spring", quotient, "1.0", "p:k", scale=1.0))
    g.add(One("1l"))
    g.add(I("Jl", constant, "p:Jl", scale=1.0))
    g.connect("U", "1i")
    g.connect("1i", "Ra")
    g.connect("1i", "La")
    g.connect("1i", "km")
    g.connect("km", "1w")
    g.connect("1w", "J")
    g.connect("1w", "b")
    g.connect("1w", "gear")
    g.connect("gear", "0s")
    g.connect("0s", "spring")
    g.connect("0s", "1l")
    g.connect("1l", "Jl")
    return g


@pytest.fixture(scope="module")
def motor():
    return compile_graph(motor_load_graph())


def test_every_state_in_integral_causality(motor):
    assert sorted(motor.state_names) == ["J", "Jl", "La", "spring"]


def test_junction_laws_and_power_continuity_at_random_states(motor):
    g = motor.system.graph
    rng = np.random.default_rng(1)
    p = motor.params()
    for _ in range(20):
        y = rng.normal(size=len(motor.state_names)) * np.array([3.0, 40.0, 2.0, 5.0])
        e, f = motor.bond_values(y, p)
        for el in g.elements.values():
            bonds = g.bonds_of(el.name)
            signs = np.array([b.sign_at(el.name) for b in bonds])
            idx = [b.index for b in bonds]
            if el.kind is Kind.ZERO:
                assert abs(np.sum(signs * f[idx])) < 1e-12 * max(1.0, np.abs(f[idx]).max())
                assert np.ptp(e[idx]) == 0.0
            elif el.kind is Kind.ONE:
                assert abs(np.sum(signs * e[idx])) < 1e-12 * max(1.0, np.abs(e[idx]).max())
                assert np.ptp(f[idx]) == 0.0
            elif el.kind in (Kind.TF, Kind.GY):
                b_in, b_out = g.two_port_bonds(el.name)
                p_in = e[b_in.index] * f[b_in.index]
                p_out = e[b_out.index] * f[b_out.index]
                assert p_in == pytest.approx(p_out, rel=1e-12, abs=1e-12)


def test_motor_steady_state_matches_hand_calculation(motor):
    # The load inertia only feels the spring, so at steady state the spring is relaxed and
    # the motor spins against its viscous loss: km·i = b·w and U = Ra·i + km·w.
    U, Ra, km, b, ratio = 12.0, 0.5, 0.05, 1e-3, 0.1
    w_hand = km * U / (Ra * b + km**2)
    i_hand = (U - km * w_hand) / Ra
    p = motor.params()
    y = motor.steady(np.array([1.0, 10.0, 0.0, 1.0]), p)
    assert y[motor.state_index("J")] == pytest.approx(w_hand, rel=1e-9)
    assert y[motor.state_index("La")] == pytest.approx(i_hand, rel=1e-9)
    assert y[motor.state_index("spring")] == pytest.approx(0.0, abs=1e-9)
    assert y[motor.state_index("Jl")] == pytest.approx(ratio * w_hand, rel=1e-9)


def test_transient_reaches_the_steady_state(motor):
    p = motor.params()
    res = motor.integrate(np.zeros(4), p, 30.0, rtol=1e-6, hmax=0.01)
    assert res.success
    y_ss = motor.steady(np.array([1.0, 10.0, 0.0, 1.0]), p)
    assert res.y[-1] == pytest.approx(y_ss, rel=2e-3, abs=1e-4)


def test_equations_print_and_export():
    g = motor_load_graph()
    text = derive_equations(g).describe()
    assert "dLa/dt" in text and "# gear" in text
    doc = json.loads(to_json(g))
    assert {e["name"] for e in doc["elements"]} == set(g.elements)
    assert all(b["effort_set_by"] in (b["from"], b["to"]) for b in doc["bonds"])
    dot = to_dot(g)
    assert dot.count("->") == len(g.bonds) and dot.startswith('digraph "motor"')


def test_two_effort_sources_on_a_zero_junction_are_named():
    g = BondGraph("conflict")
    g.parameter("u", 1.0)
    g.add(Se("S1", constant, "p:u"))
    g.add(Se("S2", constant, "p:u"))
    g.add(Zero("0a"))
    g.connect("S1", "0a")
    g.connect("S2", "0a")
    with pytest.raises(CausalityError) as exc:
        compile_graph(g)
    assert "0a" in exc.value.elements and {"S1", "S2"} & set(exc.value.elements)


def test_derivative_causality_is_named():
    g = BondGraph("dc")
    g.parameter("c", 1.0)
    g.parameter("q", 1.0)
    g.add(Sf("Q", constant, "p:q"))
    g.add(Zero("0n"))
    g.add(C("C1", constant, "p:c"))
    g.add(C("C2", constant, "p:c"))
    g.connect("Q", "0n")
    g.connect("0n", "C1")
    g.connect("0n", "C2")
    with pytest.raises(DerivativeCausalityError) as exc:
        compile_graph(g)
    assert exc.value.elements == ("C2",)


def test_algebraic_loop_is_named():
    g = BondGraph("loop")
    g.parameter("u", 1.0)
    g.parameter("r", 2.0)
    g.add(Se("U", constant, "p:u"))
    g.add(One("1a"))
    g.add(R("R1", flow=call(linear_flow, "e", "p:r")))
    g.add(Zero("0b"))
    g.add(_lin_r("R2", "r"))
    g.add(_lin_r("R3", "r"))
    g.connect("U", "1a")
    g.connect("1a", "R1")
    g.connect("1a", "0b")
    g.connect("0b", "R2")
    g.connect("0b", "R3")
    with pytest.raises(AlgebraicLoopError) as exc:
        derive_equations(g)
    assert "R1" in exc.value.elements and "algebraic loop" in str(exc.value)


def test_resistance_without_the_needed_law_is_named():
    g = BondGraph("rlaw")
    g.parameter("q", 1.0)
    g.parameter("r", 1.0)
    g.add(Sf("Q", constant, "p:q"))
    g.add(R("Rf", flow=call(linear_flow, "e", "p:r")))
    g.connect("Q", "Rf")
    with pytest.raises(CausalityError) as exc:
        compile_graph(g)
    assert exc.value.elements == ("Rf",)


def test_bond_orientation_is_checked():
    g = BondGraph("orient")
    g.parameter("c", 1.0)
    g.add(C("C1", constant, "p:c"))
    g.add(Zero("0a"))
    g.connect("C1", "0a")
    with pytest.raises(ModelStructureError) as exc:
        compile_graph(g)
    assert "C1" in exc.value.elements
