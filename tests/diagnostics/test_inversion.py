"""Inversion of the leakage laws to equivalent clearances, with uncertainty."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from diagnostics.inversion import (
    LeakageGeometry,
    cylinder_clearance,
    leakage_root,
    piston_clearance,
    piston_law_coefficients,
    spool_clearance,
    valve_clearance,
)
from diagnostics.measurement import (
    DEFAULT_INSTRUMENTS,
    MeasurementRecord,
    OperatingCondition,
    Quantity,
)
from diagnostics.uncertainty import delta_method, monte_carlo
from sim.components import cylinder, directional_valve, pump
from sim.components.cylinder import piston_leakage_flow
from sim.components.directional_valve import spool_leakage_flow
from sim.errors import InputError, MeasurementError
from sim.fluid import Fluid

CYL = {p.name: p.default for p in cylinder.PARAMETERS}
VAL = {p.name: p.default for p in directional_valve.PARAMETERS}
PUMP = {p.name: p.default for p in pump.PARAMETERS}
AREA = cylinder.annulus_area(CYL["bore"], CYL["rod1"])
GEOM = LeakageGeometry(bore=CYL["bore"], Lc=CYL["Lc"], A1=AREA, A2=AREA, Dv=VAL["Dv"],
                       Ls=VAL["Ls"], stroke=CYL["stroke"], Vp=PUMP["Vp"], speed=PUMP["speed"],
                       PRpv=9.57e4, PRvt=0.0)
FLUID = Fluid()


def simulated_record(*, cc: float, cv: float, T: float, v: float, p1: float, p2: float,
                     pp: float, geom: LeakageGeometry = GEOM, noise: np.random.Generator | None
                     = None) -> MeasurementRecord:
    """Working-phase readings the forward laws give for clearances cc, cv (paper 002 §2.7)."""
    mu = FLUID.dynamic_viscosity(T)
    q_lc = piston_leakage_flow(p1 - p2, v, cc, geom.bore, geom.Lc, mu)
    q_lv = spool_leakage_flow(pp - geom.PRpv - geom.PRvt, cv, geom.Dv, geom.Ls, mu)
    flow_c = geom.A2 * v + q_lc  # out of chamber 2
    flow_b = geom.A1 * v + q_lc + q_lv  # into chamber 1 plus the valve's P→T leak
    true = {"flow_B": flow_b, "flow_C": flow_c, "p1": p1, "p2": p2, "pump_pressure": pp,
            "speed_work": v}
    temp = T
    if noise is not None:  # draw each reading from its instrument class (rectangular)
        def draw(name: str, x: float) -> Quantity:
            q = DEFAULT_INSTRUMENTS[name].reading(x)
            return Quantity(x + q.u * noise.uniform(-math.sqrt(3), math.sqrt(3)), q.u,
                            "rectangular")
        readings: dict[str, float | Quantity] = {k: draw(k, x) for k, x in true.items()}
        temp_q = draw("condition.oil_temperature", T)
        cond = OperatingCondition(oil_temperature=temp_q, back_pressure=Quantity(p2, 1e3))
    else:
        readings = dict(true)
        cond = OperatingCondition.from_readings({"oil_temperature": temp, "back_pressure": p2})
    return MeasurementRecord.from_readings("rig-1", cond, readings)


# --- the cubic -------------------------------------------------------------------------------

def test_leakage_root_recovers_rising_branch_roots_to_round_off() -> None:
    rng = np.random.default_rng(1)
    a = 10 ** rng.uniform(3, 9, 2000)
    b = rng.choice([-1.0, 0.0, 1.0], 2000) * 10 ** rng.uniform(-4, 0, 2000)
    c_star = np.sqrt(np.abs(b) / (3 * a)) * (b > 0)
    c = c_star + 10 ** rng.uniform(-6, -3, 2000)
    q = a * c**3 - b * c
    root = leakage_root(a, b, q)
    np.testing.assert_allclose(root, c, rtol=1e-10)


def test_positive_leak_has_exactly_one_positive_root() -> None:
    rng = np.random.default_rng(2)
    for _ in range(200):
        a, b = 10 ** rng.uniform(4, 8), 10 ** rng.uniform(-4, -1)
        q = 10 ** rng.uniform(-8, -4)
        roots = np.roots([a, 0.0, -b, -q])
        positive = roots[(np.abs(roots.imag) < 1e-12 * np.abs(roots)) & (roots.real > 0)].real
        assert positive.size == 1
        assert leakage_root(a, b, q)[()] == pytest.approx(positive[0], rel=1e-9)


def test_non_positive_leak_takes_the_rising_branch_and_below_minimum_clips() -> None:
    a, b = 1e6, 1e-2
    c_star = math.sqrt(b / (3 * a))
    small = 0.5 * c_star  # falling branch: a·c³ − b·c < 0
    q = a * small**3 - b * small
    root = float(leakage_root(a, b, q)[()])
    assert root > c_star
    assert a * root**3 - b * root == pytest.approx(q, rel=1e-9)
    assert float(leakage_root(a, b, 0.0)[()]) == pytest.approx(math.sqrt(b / a))
    f_min = -(2 / 3) * b * c_star
    assert float(leakage_root(a, b, 1.5 * f_min)[()]) == pytest.approx(c_star)
    assert math.isnan(float(leakage_root(-1.0, b, 1e-6)[()]))


@pytest.mark.parametrize("dp", [2e5, -2e5])
def test_piston_clearance_is_the_inverse_of_the_sim_law_in_both_phases(dp: float) -> None:
    mu = FLUID.dynamic_viscosity(45.0)
    for cc in (40e-6, 83e-6, 150e-6, 300e-6):
        v = 0.2 if dp > 0 else -0.2  # working phase: P1 > P2 and ẋ > 0; return: both flip
        q = piston_leakage_flow(dp, v, cc, GEOM.bore, GEOM.Lc, mu)
        back = piston_clearance(q, dp, v, GEOM.bore, GEOM.Lc, mu)
        assert back == pytest.approx(cc, rel=1e-9)
    with pytest.raises(InputError):
        piston_clearance(-1e-3, 2e5, 0.2, GEOM.bore, GEOM.Lc, mu)  # below the law's minimum


def test_spool_clearance_is_the_inverse_of_the_sim_law() -> None:
    mu = FLUID.dynamic_viscosity(30.0)
    for cv in (10e-6, 34e-6, 73e-6):
        q = spool_leakage_flow(18e5, cv, GEOM.Dv, GEOM.Ls, mu)
        assert spool_clearance(q, 18e5, GEOM.Dv, GEOM.Ls, mu) == pytest.approx(cv, rel=1e-12)


# --- round trips through records -------------------------------------------------------------

@pytest.mark.parametrize("T", [22.0, 40.0, 60.0])
@pytest.mark.parametrize(("cc", "cv"), [(83e-6, 34e-6), (130e-6, 49e-6), (200e-6, 73e-6)])
@pytest.mark.parametrize(("v", "dp"), [(0.2, 2.5e5), (0.05, 20e5)])
def test_round_trip_recovers_clearances(T: float, cc: float, cv: float, v: float,
                                        dp: float) -> None:
    rec = simulated_record(cc=cc, cv=cv, T=T, v=v, p1=10e5 + dp, p2=10e5, pp=10e5 + dp + 4e5)
    est_c = cylinder_clearance(rec, GEOM, fluid=FLUID)
    est_v = valve_clearance(rec, GEOM, fluid=FLUID)
    assert est_c.value == pytest.approx(cc, rel=1e-9)
    assert est_v.value == pytest.approx(cv, rel=1e-9)
    assert est_c.low <= est_c.value <= est_c.high
    assert est_v.low <= est_v.value <= est_v.high


def test_round_trip_with_unequal_areas_uses_the_area_flow() -> None:
    geom = replace(GEOM, A1=math.pi * GEOM.bore**2 / 4)  # single-rod cylinder, rod side 2
    rec = simulated_record(cc=90e-6, cv=40e-6, T=40.0, v=0.1, p1=13e5, p2=10e5, pp=17e5,
                           geom=geom)
    assert valve_clearance(rec, geom, fluid=FLUID).value == pytest.approx(40e-6, rel=1e-9)
    assert cylinder_clearance(rec, geom, fluid=FLUID).value == pytest.approx(90e-6, rel=1e-9)


@pytest.mark.parametrize("ratio", [0.3, 0.6, 0.9, 1.2, 1.5])
def test_both_roots_of_a_negative_bypass_are_given_and_the_one_nearer_the_rig_is_the_value(
        ratio: float) -> None:
    """Where the piston's drag outweighs its leak two clearances give one bypass, either
    side of c*: the healthy reference rig at −30 °C read 309 µm [207, 434] for its 83 µm,
    from the rising root alone (an edge pass).  With the rig's own clearance the nearer root
    is the value, the interval holds both, and the note names both."""
    T, v, dp = 22.0, 0.2, 0.5e5
    c_star = math.sqrt(2 * FLUID.dynamic_viscosity(T) * GEOM.Lc * v / dp)
    cc = ratio * c_star
    rec = simulated_record(cc=cc, cv=34e-6, T=T, v=v, p1=10e5 + dp, p2=10e5, pp=15e5)
    est = cylinder_clearance(rec, GEOM, fluid=FLUID, reference=cc, method="delta")
    assert est.derived["Q_lc"] < 0.0
    assert est.value == pytest.approx(cc, rel=1e-6)
    other = est.derived["other_root"]
    assert (other - c_star) * (cc - c_star) < 0  # the other side of c*
    a_unit, b_unit = piston_law_coefficients(GEOM.bore, GEOM.Lc)
    mu = FLUID.dynamic_viscosity(T)
    for c in (cc, other):  # both give the bypass
        law = a_unit * dp / mu * c**3 - b_unit * v * c
        assert law == pytest.approx(est.derived["Q_lc"], rel=1e-6, abs=1e-15)
    assert est.low <= min(cc, other) and est.high >= max(cc, other)
    assert est.low < est.value  # not collapsed on the value (a verification pass)
    assert any("two clearances give this bypass" in n for n in est.notes)
    # without the rig's clearance, the rising root as before
    assert cylinder_clearance(rec, GEOM, fluid=FLUID).value == pytest.approx(max(cc, other),
                                                                            rel=1e-6)


def test_negative_bypass_on_rising_branch_is_recovered_and_flagged() -> None:
    # thick oil, small pressure difference: between c* = √(2μLv/ΔP) and √3·c* the Couette
    # drag exceeds the Poiseuille flow, so the bypass is negative on the rising branch
    T, v, dp = 22.0, 0.2, 0.5e5
    c_star = math.sqrt(2 * FLUID.dynamic_viscosity(T) * GEOM.Lc * v / dp)
    cc = 1.3 * c_star
    rec = simulated_record(cc=cc, cv=34e-6, T=T, v=v, p1=10e5 + dp, p2=10e5, pp=15e5)
    est = cylinder_clearance(rec, GEOM, fluid=FLUID)
    assert est.derived["Q_lc"] < 0.0
    assert est.derived["c_star"] == pytest.approx(c_star, rel=1e-12)
    assert est.value == pytest.approx(cc, rel=1e-9)
    assert any("second, smaller root" in n for n in est.notes)


# --- physics of the estimates ----------------------------------------------------------------

def test_warmer_oil_means_smaller_clearance_for_the_same_flows() -> None:
    base = simulated_record(cc=120e-6, cv=50e-6, T=40.0, v=0.15, p1=25e5, p2=10e5, pp=30e5)
    values = []
    for T in (30.0, 40.0, 50.0):
        cond = OperatingCondition.from_readings({"oil_temperature": T, "back_pressure": 10e5})
        rec = MeasurementRecord(**{**{f: getattr(base, f) for f in
                                      ("rig_id", "flow_B", "flow_C", "p1", "p2",
                                       "pump_pressure", "speed_work")}, "condition": cond})
        values.append((cylinder_clearance(rec, GEOM, fluid=FLUID).value,
                       valve_clearance(rec, GEOM, fluid=FLUID).value))
    cc, cv = zip(*values, strict=True)
    assert cc[0] > cc[1] > cc[2] and cv[0] > cv[1] > cv[2]
    # spool law: cv ∝ μ^(1/3)
    mu = [FLUID.dynamic_viscosity(T) for T in (30.0, 50.0)]
    assert cv[0] / cv[2] == pytest.approx((mu[0] / mu[1]) ** (1 / 3), rel=1e-9)


def test_sensitivities_have_physical_signs_and_contributions_sum_to_one() -> None:
    rec = simulated_record(cc=150e-6, cv=60e-6, T=40.0, v=0.1, p1=30e5, p2=10e5, pp=35e5)
    est = cylinder_clearance(rec, GEOM, fluid=FLUID)
    s = est.sensitivities
    assert s["flow_C"] > 0 and s["speed_work"] < 0 and s["p1"] < 0 and s["p2"] > 0
    assert s["oil_temperature"] < 0  # warmer oil, thinner: the same flow needs less clearance
    assert sum(est.contributions.values()) == pytest.approx(1.0)
    val = valve_clearance(rec, GEOM, fluid=FLUID)
    assert val.sensitivities["flow_B"] > 0 and val.sensitivities["flow_C"] < 0
    # delta method for the cube root: u(cv)/cv = u(Q)/(3Q) when flows dominate
    rel_q = val.derived["u_Q_lv"] / val.derived["Q_lv"]
    flow_part = math.sqrt(val.contributions["flow_B"] + val.contributions["flow_C"])
    assert val.relative * flow_part == pytest.approx(rel_q / 3, rel=1e-4)


# --- delta method against Monte Carlo --------------------------------------------------------

def test_delta_method_agrees_with_monte_carlo_where_linear() -> None:
    rec = simulated_record(cc=200e-6, cv=73e-6, T=40.0, v=0.05, p1=30e5, p2=10e5, pp=36e5)
    for invert in (cylinder_clearance, valve_clearance):
        d = invert(rec, GEOM, fluid=FLUID, method="delta")
        m = invert(rec, GEOM, fluid=FLUID, method="monte-carlo", n=40_000, rng=np.random.default_rng(3))
        assert d.value == m.value
        assert m.u == pytest.approx(d.u, rel=0.05)
        assert m.low == pytest.approx(d.low, rel=0.02)
        assert m.high == pytest.approx(d.high, rel=0.02)
        assert m.valid_fraction == 1.0


def test_monte_carlo_samples_rectangular_inputs_as_rectangles() -> None:
    q = {"x": Quantity.from_bound(1.0, 0.5)}
    est = monte_carlo(lambda x: x["x"], q, quantity="x", unit="1", n=50_000,
                      rng=np.random.default_rng(4))
    assert est.u == pytest.approx(0.5 / math.sqrt(3), rel=0.02)
    assert est.low == pytest.approx(1.0 - 0.95 * 0.5, abs=0.01)  # uniform percentiles
    assert est.low >= 0.5 and est.high <= 1.5


def test_delta_intervals_cover_the_truth_about_95_percent() -> None:
    rng = np.random.default_rng(5)
    truth = {"cc": 160e-6, "cv": 60e-6}
    hits = {"cc": 0, "cv": 0}
    n = 400
    for _ in range(n):
        rec = simulated_record(cc=truth["cc"], cv=truth["cv"], T=40.0, v=0.05, p1=30e5, p2=10e5,
                               pp=36e5, noise=rng)
        for name, invert in (("cc", cylinder_clearance), ("cv", valve_clearance)):
            est = invert(rec, GEOM, fluid=FLUID, method="delta")
            hits[name] += est.low <= truth[name] <= est.high
    # ≥ 95 % nominal; rectangular inputs make ±1.96·u conservative (about 99 % for cc)
    for name in hits:
        assert 0.92 <= hits[name] / n <= 1.0, (name, hits[name] / n)


def test_auto_switches_to_monte_carlo_where_nonlinear_and_covers() -> None:
    # the nominal rig: the piston bypass is about the flowmeter's uncertainty (nonlinear)
    nominal: dict[str, Any] = dict(cc=83e-6, cv=34e-6, T=40.0, v=0.2, p1=12.5e5, p2=10e5,
                                   pp=20e5)
    est = cylinder_clearance(simulated_record(**nominal), GEOM, fluid=FLUID)
    assert est.method == "monte-carlo"
    assert est.contributions  # the delta method's ranking of the sensors is kept
    # skewed: near c* (flat bottom of the law) small bypass errors move cc a lot
    assert abs((est.high - est.value) - (est.value - est.low)) > 0.1 * (est.high - est.low)
    rng = np.random.default_rng(6)
    hits, n = 0, 150
    for _ in range(n):
        est = cylinder_clearance(simulated_record(**nominal, noise=rng), GEOM, fluid=FLUID, n=2000, rng=rng)
        hits += est.low <= 83e-6 <= est.high
    assert 0.9 <= hits / n <= 0.99
    clear = simulated_record(cc=200e-6, cv=73e-6, T=40.0, v=0.05, p1=30e5, p2=10e5, pp=36e5)
    assert cylinder_clearance(clear, GEOM, fluid=FLUID).method == "delta"


# --- refused inputs --------------------------------------------------------------------------

def test_missing_fields_and_contradictions_raise_measurement_error() -> None:
    rec = simulated_record(cc=83e-6, cv=34e-6, T=40.0, v=0.2, p1=12.5e5, p2=10e5, pp=20e5)
    no_p1 = MeasurementRecord(rig_id="r", condition=rec.condition, flow_C=rec.flow_C,
                              p2=rec.p2, speed_work=rec.speed_work)
    with pytest.raises(MeasurementError) as err:
        cylinder_clearance(no_p1, GEOM, fluid=FLUID)
    assert err.value.field == "p1"
    no_speed = MeasurementRecord(rig_id="r", condition=rec.condition, flow_C=rec.flow_C,
                                 p1=rec.p1, p2=rec.p2)
    with pytest.raises(MeasurementError) as err:
        cylinder_clearance(no_speed, GEOM, fluid=FLUID)
    assert err.value.field == "speed_work"
    reversed_dp = MeasurementRecord(rig_id="r", condition=rec.condition, flow_C=rec.flow_C,
                                    p1=rec.p2, p2=rec.p1, speed_work=rec.speed_work)
    with pytest.raises(MeasurementError) as err:
        cylinder_clearance(reversed_dp, GEOM, fluid=FLUID)
    assert err.value.field == "p1"
    assert rec.flow_C is not None and rec.flow_B is not None
    starved = MeasurementRecord(rig_id="r", condition=rec.condition,
                                flow_C=Quantity(0.9 * rec.flow_C.value, rec.flow_C.u),
                                p1=rec.p1, p2=rec.p2, speed_work=rec.speed_work)
    with pytest.raises(MeasurementError) as err:
        cylinder_clearance(starved, GEOM, fluid=FLUID)
    assert err.value.field == "flow_C"
    negative_valve = MeasurementRecord(rig_id="r", condition=rec.condition,
                                       flow_B=Quantity(0.9 * rec.flow_C.value, 1e-7),
                                       flow_C=Quantity(rec.flow_C.value, 1e-7),
                                       pump_pressure=rec.pump_pressure)
    with pytest.raises(MeasurementError) as err:
        valve_clearance(negative_valve, GEOM, fluid=FLUID)
    assert err.value.field == "flow_C"


def test_a_bypass_within_noise_of_zero_has_an_upper_bound_even_by_the_delta_method() -> None:
    """The diagnosis inverts by the delta method; at a valve bypass a quarter of its
    uncertainty below zero the law's clip made its derivative 0 and the interval [0, 0]
    (an engineer's pass: a zero-width "no clearance" point stored in the valve trend).
    Now [0, the clearance of the bypass's upper bound], the same on every call."""
    clean = simulated_record(cc=83e-6, cv=1e-9, T=40.0, v=0.2, p1=12.5e5, p2=10e5, pp=16.5e5)
    u_q = math.hypot(clean.flow_B.u, clean.flow_C.u)  # type: ignore[union-attr]
    flow_b = clean.flow_B
    assert flow_b is not None
    rec = replace(clean, flow_B=Quantity(flow_b.value - 0.25 * u_q, flow_b.u))
    est = valve_clearance(rec, GEOM, fluid=FLUID, method="delta")
    assert est.value == 0.0 and est.low == 0.0
    mu = FLUID.dynamic_viscosity(40.0)
    dp = 16.5e5 - GEOM.PRpv - GEOM.PRvt
    q_hi = (1.96 - 0.25) * u_q  # the bypass's upper bound, its own uncertainty dominating
    assert est.high == pytest.approx(spool_clearance(q_hi, dp, GEOM.Dv, GEOM.Ls, mu), rel=0.15)
    again = valve_clearance(rec, GEOM, fluid=FLUID, method="delta")
    assert (again.low, again.high) == (est.low, est.high)
    # away from the bound the delta method is kept
    assert valve_clearance(clean_with(cv=40e-6), GEOM, fluid=FLUID, method="delta").method == "delta"


def clean_with(*, cv: float) -> MeasurementRecord:
    return simulated_record(cc=83e-6, cv=cv, T=40.0, v=0.2, p1=12.5e5, p2=10e5, pp=16.5e5)


def test_the_bypass_uncertainty_combines_the_flowmeter_and_the_speed() -> None:
    # Q_lc = Q_C − A2·ẋ (the flow balance of chamber 2): its standard uncertainty is the
    # GUM sum of the flowmeter's and the speed's parts, √(u(Q_C)² + (A2·u(ẋ))²); here the
    # speed's part is half the meter's, so leaving it out (a mutation review) shows
    rec = simulated_record(cc=90e-6, cv=40e-6, T=40.0, v=0.1, p1=13e5, p2=10e5, pp=17e5)
    speed = rec.speed("work", stroke=Quantity(GEOM.stroke))
    assert rec.flow_C is not None and speed is not None
    balance = delta_method(lambda x: x["flow_C"] - GEOM.A2 * x["v"],
                           {"flow_C": rec.flow_C, "v": speed}, quantity="Q_lc", unit="m^3/s")
    assert GEOM.A2 * speed.u > 0.3 * rec.flow_C.u
    est = cylinder_clearance(rec, GEOM, fluid=FLUID)
    assert est.derived["Q_lc"] == pytest.approx(balance.value, rel=1e-12)
    assert est.derived["u_Q_lc"] == pytest.approx(balance.u, rel=1e-6)


def test_the_spool_sees_the_pump_pressure_less_both_line_drops() -> None:
    # paper 002 eqs. 8, 24: ΔP across the lands = P_pump − PRpv − PRvt.  With a valve-to-tank
    # drop as large as the pump-to-valve one (the reference geometry has none), the round
    # trip holds only if both are taken off; with PRvt left out the 1 bar too much of a
    # 15 bar difference reads a clearance 2 % small (a mutation review)
    geom = replace(GEOM, PRvt=1e5)
    rec = simulated_record(cc=90e-6, cv=40e-6, T=40.0, v=0.1, p1=13e5, p2=10e5, pp=17e5,
                           geom=geom)
    est = valve_clearance(rec, geom, fluid=FLUID)
    assert est.value == pytest.approx(40e-6, rel=1e-9)
    assert est.derived["dp"] == pytest.approx(17e5 - 9.57e4 - 1e5, rel=1e-12)
