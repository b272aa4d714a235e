"""Measurement records: uncertainty conventions, validation, consistency with the rig."""

from __future__ import annotations

import math

import pytest

from diagnostics.consistency import RigLimits, check_against_rig
from diagnostics.measurement import (
    CONSISTENCY_K,
    DEFAULT_INSTRUMENTS,
    MeasurementRecord,
    OperatingCondition,
    Quantity,
)
from sim.components import cylinder, pump
from sim.errors import MeasurementError

PUMP = {p.name: p.default for p in pump.PARAMETERS}
CYL = {p.name: p.default for p in cylinder.PARAMETERS}
AREA = cylinder.annulus_area(CYL["bore"], CYL["rod1"])
LIMITS = RigLimits(Vp=PUMP["Vp"], speed=PUMP["speed"], A1=AREA, A2=AREA, stroke=CYL["stroke"])
V_MAX = PUMP["Vp"] * PUMP["speed"] / AREA  # ≈ 0.22 m/s on paper 002's rig


def cond(**kw: float | Quantity) -> OperatingCondition:
    return OperatingCondition.from_readings({"oil_temperature": 40.0, "back_pressure": 10e5, **kw})


def record(**readings: float | Quantity) -> MeasurementRecord:
    return MeasurementRecord.from_readings("rig-1", cond(), readings)


# --- uncertainty conventions -------------------------------------------------------------

def test_bound_is_rectangular_with_u_a_over_sqrt3() -> None:
    q = Quantity.from_bound(10.0, 0.3)
    assert q.u == pytest.approx(0.3 / math.sqrt(3.0))
    assert q.distribution == "rectangular"
    e = Quantity.from_expanded(10.0, 0.3, k=2.0)
    assert (e.u, e.distribution) == (pytest.approx(0.15), "normal")


def test_instrument_classes_of_paper_000() -> None:
    flow = DEFAULT_INSTRUMENTS["flow_C"].reading(4.0e-4)
    assert flow.u == pytest.approx(0.01 * 4.0e-4 / math.sqrt(3.0))
    p = DEFAULT_INSTRUMENTS["p1"].reading(-2.0e5)  # relative to |reading|
    assert p.u == pytest.approx(0.0025 * 2.0e5 / math.sqrt(3.0))
    t = DEFAULT_INSTRUMENTS["condition.oil_temperature"].reading(40.0)
    assert t.u == pytest.approx(1.0 / math.sqrt(3.0))


def test_from_readings_uses_default_class_and_keeps_stated_u() -> None:
    rec = record(flow_C=4.0e-4, p1=Quantity(12e5, 1e3))
    assert rec.flow_C is not None and rec.flow_C.distribution == "rectangular"
    assert rec.p1 == Quantity(12e5, 1e3)
    assert rec.flow_B is None


def test_unknown_field_is_named() -> None:
    with pytest.raises(MeasurementError) as err:
        record(flow_D=1.0)
    assert err.value.field == "flow_D"


# --- field validation -----------------------------------------------------------------------

@pytest.mark.parametrize("name", ["pump_pressure", "p1", "p2", "flow_B", "flow_C", "pump_flow",
                                  "speed_work", "speed_return", "duration_work", "stroke",
                                  "velocity_ratio"])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_values_are_refused_with_their_path(name: str, bad: float) -> None:
    with pytest.raises(MeasurementError) as err:
        record(**{name: Quantity(bad, 0.0)})
    assert err.value.field == name


@pytest.mark.parametrize("u", [math.nan, -1e-6, math.inf])
def test_bad_uncertainty_points_at_u(u: float) -> None:
    with pytest.raises(MeasurementError) as err:
        record(flow_B=Quantity(4e-4, u))
    assert err.value.field == "flow_B.u"


@pytest.mark.parametrize(("name", "value"), [("flow_B", -1e-7), ("flow_C", -1e-6),
                                             ("p1", -1.01e5), ("pump_pressure", -2e5),
                                             ("duration_work", -1.0), ("duration_return", 0.0),
                                             ("speed_work", -0.1), ("stroke", 0.0),
                                             ("velocity_ratio", 0.0)])
def test_impossible_values(name: str, value: float) -> None:
    with pytest.raises(MeasurementError) as err:
        record(**{name: value})
    assert err.value.field == name


def test_vacuum_down_to_minus_one_bar_is_accepted() -> None:
    assert record(p2=-0.9e5).p2 is not None


@pytest.mark.parametrize(("name", "value"), [("p1", 1.01e9), ("pump_pressure", 1e12),
                                             ("p2", 1e300), ("flow_C", 1e300),
                                             ("duration_work", 1e101), ("stroke", 1e300)])
def test_readings_beyond_any_instrument_are_refused(name: str, value: float) -> None:
    """A pressure above 10 kbar, or any number above 1e100 (its square, which weighs the
    reading, overflowed: a 1e300 bar reading dropped out of the fit unnoticed)."""
    with pytest.raises(MeasurementError) as err:
        record(**{name: value})
    assert err.value.field == name
    assert record(p1=9.9e8).p1 is not None  # 9.9 kbar: an ultra-high-pressure transducer


def test_an_uncertainty_that_states_nothing_is_refused() -> None:
    with pytest.raises(MeasurementError) as err:
        record(p1=Quantity(12e5, 1e300))
    assert err.value.field == "p1.u" and "leave the reading out" in err.value.message


def test_condition_validation() -> None:
    with pytest.raises(MeasurementError) as err:
        OperatingCondition.from_readings({"oil_temperature": 40.0})
    assert err.value.field == "condition.load_force"
    with pytest.raises(MeasurementError) as err:
        OperatingCondition.from_readings({"oil_temperature": math.nan, "load_force": 2.1e3})
    assert err.value.field == "condition.oil_temperature"
    with pytest.raises(MeasurementError) as err:
        OperatingCondition.from_readings({"oil_temperature": 400.0, "load_force": 2.1e3})
    assert err.value.field == "condition.oil_temperature"
    assert err.value.message == ("oil temperature above 150 °C is not a plausible reading "
                                 "(400 reads as 126.9 °C if it is in K: send °C)")
    with pytest.raises(MeasurementError) as err:  # 60 °C logged in °F
        OperatingCondition.from_readings({"oil_temperature": 160.0, "load_force": 2.1e3})
    assert err.value.message.endswith("(160 reads as 71.1 °C if it is in °F: send °C)")
    with pytest.raises(MeasurementError) as err:  # neither
        OperatingCondition.from_readings({"oil_temperature": 900.0, "load_force": 2.1e3})
    assert err.value.message == "oil temperature above 150 °C is not a plausible reading"
    with pytest.raises(MeasurementError) as err:
        OperatingCondition.from_readings({"back_pressure": 1e6})
    assert err.value.field == "condition.oil_temperature"
    with pytest.raises(MeasurementError) as err:  # the bound with its unit (a user pass)
        OperatingCondition.from_readings({"oil_temperature": -300.0, "load_force": 2.1e3})
    assert err.value.message == "oil temperature must be ≥ -40 °C, got -300 °C"
    with pytest.raises(MeasurementError) as err:
        OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": 2.1e3,
                                          "pump_speed": -1.0})
    assert err.value.field == "condition.pump_speed"
    for speed in (0.0, 2001.0, 1e9):  # at rest, or faster than any hydraulic pump
        with pytest.raises(MeasurementError) as err:
            OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": 2.1e3,
                                              "pump_speed": speed})
        assert err.value.field == "condition.pump_speed"
    with pytest.raises(MeasurementError) as err:
        OperatingCondition.from_readings({"oil_temperature": 40.0, "back_pressure": 2e9})
    assert err.value.field == "condition.back_pressure"


def test_missing_rig_is_refused() -> None:
    with pytest.raises(MeasurementError) as err:
        MeasurementRecord(rig_id=" ", condition=cond())
    assert err.value.field == "rig_id"


# --- internal contradictions ----------------------------------------------------------------

def test_ratio_contradicting_speeds_is_refused() -> None:
    vw, vr = Quantity(0.20, 0.001), Quantity(0.25, 0.001)  # ratio 0.800 ± 0.005
    with pytest.raises(MeasurementError) as err:
        record(speed_work=vw, speed_return=vr, velocity_ratio=Quantity(0.9, 0.005))
    assert err.value.field == "velocity_ratio"
    # within CONSISTENCY_K combined standard uncertainties it is accepted
    u = math.hypot(0.005, 0.8 * math.hypot(0.001 / 0.2, 0.001 / 0.25))
    ok = record(speed_work=vw, speed_return=vr,
                velocity_ratio=Quantity(0.8 + 0.95 * CONSISTENCY_K * u, 0.005))
    assert ok.ratio() is not None and ok.ratio().value == pytest.approx(0.8)  # type: ignore[union-attr]


def test_durations_contradicting_speeds_are_refused() -> None:
    with pytest.raises(MeasurementError) as err:  # 0.5 m in 2.0 s is 0.25 m/s, not 0.20
        record(speed_work=0.20, duration_work=2.0, stroke=0.5)
    assert err.value.field == "speed_work"
    with pytest.raises(MeasurementError) as err:  # ratio from durations 2.0/2.5 vs speeds 1.0
        record(speed_work=0.2, speed_return=0.2, duration_work=2.5, duration_return=2.0)
    assert err.value.field == "duration_return"


def test_speed_from_durations_and_inverse_variance_combination() -> None:
    rec = record(duration_work=Quantity(2.5, 0.01), stroke=Quantity(0.5, 0.0))
    v = rec.speed("work")
    assert v is not None
    assert v.value == pytest.approx(0.2)
    assert v.u == pytest.approx(0.2 * 0.01 / 2.5)
    both = record(duration_work=Quantity(2.5, 0.01), stroke=Quantity(0.5, 0.0),
                  speed_work=Quantity(0.201, 0.0008))
    c = both.speed("work")
    assert c is not None
    w1, w2 = 1 / 0.0008**2, 1 / 0.0008**2
    assert c.value == pytest.approx((0.2 * w1 + 0.201 * w2) / (w1 + w2))
    assert c.u == pytest.approx(0.0008 / math.sqrt(2.0))
    # the stroke can come from the rig when the record has none
    no_stroke = record(duration_work=2.5)
    assert no_stroke.speed("work") is None
    assert no_stroke.speed("work", stroke=Quantity(0.5)) is not None


def test_ratio_from_durations_needs_no_stroke() -> None:
    rec = record(duration_work=2.5, duration_return=2.0)
    r = rec.ratio()
    assert r is not None and r.value == pytest.approx(0.8)


# --- limits of the rig ----------------------------------------------------------------------

def test_speed_above_pump_maximum_is_refused() -> None:
    check_against_rig(record(speed_work=0.98 * V_MAX), LIMITS)
    with pytest.raises(MeasurementError) as err:
        check_against_rig(record(speed_work=1.2 * V_MAX), LIMITS)
    assert err.value.field == "speed_work"
    with pytest.raises(MeasurementError) as err:  # too short a stroke time, rig's stroke
        check_against_rig(record(duration_return=0.5 * CYL["stroke"] / V_MAX), LIMITS)
    assert err.value.field == "duration_return"


@pytest.mark.parametrize("fraction", [0.5, 0.1, 0.02, 0.002])
def test_a_stroke_time_too_short_is_refused_however_short(fraction: float) -> None:
    """The speed from stroke/duration has an uncertainty s·u_t/t² that grows without bound
    as t nears the timer's: 0.01 s for the 0.5 m stroke (50 m/s) passed the speed check and
    read as healthy, p = 1, where 0.1 s was refused (an edge pass).  The duration itself is
    held against the stroke's shortest time."""
    shortest = CYL["stroke"] / V_MAX
    with pytest.raises(MeasurementError) as err:
        check_against_rig(record(duration_work=fraction * shortest), LIMITS)
    assert err.value.field == "duration_work" and "shorter than" in err.value.message
    check_against_rig(record(duration_work=1.02 * shortest), LIMITS)


def test_a_flow_in_l_per_min_is_refused_saying_so() -> None:
    """28 (l/min) typed as m³/s was refused without the hint bar and kN get (a user
    pass); a flow a little beyond the pump's is refused without it."""
    q_max = PUMP["Vp"] * PUMP["speed"]
    with pytest.raises(MeasurementError) as err:
        check_against_rig(record(flow_B=0.9 * q_max * 60000.0), LIMITS)
    assert err.value.field == "flow_B" and "are these l/min?" in err.value.message
    with pytest.raises(MeasurementError) as err:
        check_against_rig(record(pump_flow=1.5 * q_max), LIMITS)
    assert "l/min" not in err.value.message


def test_a_rig_whose_pump_turns_faster_than_stated_allows_the_faster_piston() -> None:
    # the discrepancy workflow stores a speed-reading offset Δω as an effect of the rig; its
    # limits are those of ω + Δω, or the cycles it was fitted to are refused
    import dataclasses

    from diagnostics.diagnose import diagnose
    from sim.rigs import load_rig, reference_rig_document
    from tests.diagnostics.synth import record as synthetic

    fast = dataclasses.replace(LIMITS, speed_offset=0.1 * PUMP["speed"])
    check_against_rig(record(speed_work=1.05 * V_MAX), fast)
    with pytest.raises(MeasurementError):
        check_against_rig(record(speed_work=1.05 * V_MAX), LIMITS)
    doc = reference_rig_document()
    doc["effects"] = {"speed_offset": {"parameters": {"d_speed": {"value": 8.0,
                                                                  "unit": "rad/s"}}}}
    rig = load_rig(doc)
    cycles = synthetic(rig, {}, load=1000.0)   # its own healthy cycle
    assert diagnose(rig, [cycles]).top.name == "healthy"


def test_speed_limit_follows_the_measured_pump_speed() -> None:
    slow = OperatingCondition.from_readings({"oil_temperature": 40.0, "back_pressure": 10e5,
                                             "pump_speed": 0.5 * PUMP["speed"]})
    rec = MeasurementRecord.from_readings("rig-1", slow, {"speed_work": 0.8 * V_MAX})
    with pytest.raises(MeasurementError):
        check_against_rig(rec, LIMITS)


def test_flows_against_the_pump_and_each_other() -> None:
    q_max = PUMP["Vp"] * PUMP["speed"]
    with pytest.raises(MeasurementError) as err:
        check_against_rig(record(flow_B=1.1 * q_max), LIMITS)
    assert err.value.field == "flow_B"
    with pytest.raises(MeasurementError) as err:  # meter C cannot exceed meter B (A1 = A2)
        check_against_rig(record(flow_B=3.0e-4, flow_C=3.2e-4), LIMITS)
    assert err.value.field == "flow_C"
    check_against_rig(record(flow_B=3.0e-4, flow_C=3.01e-4), LIMITS)  # within noise


def test_load_and_back_pressure_must_agree() -> None:
    both = OperatingCondition.from_readings({"oil_temperature": 40.0, "back_pressure": 10e5,
                                             "load_force": 10e5 * AREA})
    check_against_rig(MeasurementRecord("rig-1", both), LIMITS)
    wrong = OperatingCondition.from_readings({"oil_temperature": 40.0, "back_pressure": 10e5,
                                              "load_force": 4.2e3})
    with pytest.raises(MeasurementError) as err:
        check_against_rig(MeasurementRecord("rig-1", wrong), LIMITS)
    assert err.value.field == "condition.load_force"


def test_pressures_that_cannot_push_the_stated_load_are_refused_as_a_unit_slip() -> None:
    loaded = OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": 2100.0})
    moving = {"speed_work": 0.18}
    ok = MeasurementRecord.from_readings("rig-1", loaded, {"p1": 11.88e5, **moving})
    check_against_rig(ok, LIMITS)  # 11.9 bar × A1 = 2.35 kN ≥ 2.1 kN
    for name in ("p1", "pump_pressure"):  # bar typed where Pa is asked
        bar = MeasurementRecord.from_readings("rig-1", loaded, {name: 11.88, **moving})
        with pytest.raises(MeasurementError) as err:
            check_against_rig(bar, LIMITS)
        assert err.value.field == name and "are these bar?" in err.value.message
    # a piston that does not move may be held by a relief stuck open: a fault, not a unit
    held = MeasurementRecord.from_readings("rig-1", loaded, {"p1": 2.0e5})
    check_against_rig(held, LIMITS)


def test_a_load_in_kn_typed_as_newtons_is_refused_as_a_unit_slip() -> None:
    """2.1 for 2.1 kN: the chambers push ~2.35 kN while the piston moves (an engineer's
    pass read "unexplained, p1 by +178.6 σ"); a small real load, or none, is kept."""
    moving = {"p1": 11.88e5, "p2": 0.5e5, "speed_work": 0.18}
    kn = OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": 2.1})
    with pytest.raises(MeasurementError) as err:
        check_against_rig(MeasurementRecord.from_readings("rig-1", kn, moving), LIMITS)
    assert err.value.field == "condition.load_force" and "is this kN?" in err.value.message
    for load in (0.0, 2100.0):
        ok = OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": load})
        check_against_rig(MeasurementRecord.from_readings("rig-1", ok, moving), LIMITS)
    # friction alone at no load: ~0.8 bar on the annulus, far below the 1 kN floor
    light = OperatingCondition.from_readings({"oil_temperature": 40.0, "load_force": 1.0})
    check_against_rig(MeasurementRecord.from_readings(
        "rig-1", light, {"p1": 0.8e5, "p2": 0.0, "speed_work": 0.2}), LIMITS)


def test_stroke_against_rig() -> None:
    with pytest.raises(MeasurementError) as err:
        check_against_rig(record(stroke=0.4), LIMITS)
    assert err.value.field == "stroke"


def test_a_quotient_by_a_reading_near_the_smallest_float_has_an_uncertainty() -> None:
    """GUM eq. 12 for a/b: u = √((u_a/b)² + (a/b · u_b/b)²); a divisor of 4.6e-279 squares
    to zero, which once raised ZeroDivisionError (found by the property test of the
    /diagnose form)."""
    from diagnostics.quantity import Quantity, quotient

    tiny = Quantity(4.5592642422275285e-279, 1.3161462187783494e-281)
    q = quotient(Quantity(0.0, 0.0), tiny)
    assert q.value == 0.0 and q.u == 0.0
    q = quotient(Quantity(2.0, 0.02), Quantity(4.0, 0.04))
    assert q.value == 0.5 and math.isclose(q.u, 0.5 * math.hypot(0.01, 0.01))


def test_meter_c_beyond_meter_b_names_the_area_term_it_quoted() -> None:
    """On a differential cylinder the message quoted meter B less (A1 − A2)·ẋ as "the flow
    meter B feeds" without saying so (a user pass); it now names both parts."""
    a1 = AREA
    a2 = 0.75 * AREA
    diff = RigLimits(Vp=PUMP["Vp"], speed=PUMP["speed"], A1=a1, A2=a2, stroke=CYL["stroke"])
    v = 0.1
    with pytest.raises(MeasurementError) as err:
        check_against_rig(record(flow_B=4.0e-4, flow_C=4.0e-4, speed_work=v), diff)
    assert err.value.field == "flow_C"
    kept = (a1 - a2) * v
    assert f"meter B's {4.0e-4:.4g} less (A1 − A2)·ẋ = {kept:.4g} m³/s" in err.value.message
    with pytest.raises(MeasurementError) as err:   # equal areas: nothing to name
        check_against_rig(record(flow_B=4.0e-4, flow_C=4.5e-4, speed_work=v), LIMITS)
    assert "(A1 − A2)" not in err.value.message


def test_numpy_scalars_are_readings_and_a_bool_is_not() -> None:
    """A float32 or int64 reading (a column of a numpy array) was refused where the
    simulator takes it (a verification pass)."""
    import numpy as np

    cond = OperatingCondition.from_readings({"oil_temperature": np.float32(40.0),
                                             "load_force": np.int64(2100)})
    rec = MeasurementRecord.from_readings("1", cond, {"p1": np.float32(11.9e5),
                                                      "flow_B": np.array(4.4e-4)})
    assert rec.p1 is not None and rec.p1.value == 1.19e6 and cond.load_force.value == 2100.0
    assert rec.flow_B is not None and rec.flow_B.value == 4.4e-4
    with pytest.raises(MeasurementError, match="got bool") as caught:
        MeasurementRecord.from_readings("1", cond, {"p1": np.bool_(True)})
    assert caught.value.field == "p1"


def test_an_oil_temperature_uncertainty_that_states_nothing_is_refused_naming_it() -> None:
    """u = 1e9 K was stepped through the viscosity law and refused as "oil temperature
    100040 °C" on field ``record.T``, neither sent (an edge pass)."""
    from diagnostics.measurement import MAX_TEMPERATURE_U

    with pytest.raises(MeasurementError) as err:
        OperatingCondition.from_readings({"oil_temperature": Quantity(40.0, 1e9),
                                          "load_force": 2100.0})
    assert err.value.field == "condition.oil_temperature.u"
    assert "1e+09 K" in err.value.message
    kept = OperatingCondition.from_readings({"oil_temperature": Quantity(40.0, 20.0),
                                             "load_force": 2100.0})
    assert kept.oil_temperature.u == 20.0 < MAX_TEMPERATURE_U


@pytest.mark.parametrize(("build", "field"), [
    (lambda: OperatingCondition.from_readings([("oil_temperature", 40.0)]), "condition"),
    (lambda: MeasurementRecord.from_readings("r", cond(), [("p1", 1e6)]), "readings"),
    (lambda: MeasurementRecord.from_readings("r", cond(), {"p1": Quantity("11.88e5", 1e3)}),
     "p1"),
    (lambda: MeasurementRecord.from_readings("r", cond(), {"p1": Quantity(11.88e5, "1e3")}),
     "p1.u"),
    (lambda: MeasurementRecord.from_readings("r", cond(), {"p1": 10**400}), "p1"),
    (lambda: MeasurementRecord.from_readings("r", cond(), {"p1": Quantity(10**400, 1.0)}),
     "p1"),
    (lambda: OperatingCondition.from_readings({"oil_temperature": 10**400}),
     "condition.oil_temperature"),
])
def test_a_reading_of_the_wrong_type_is_a_measurement_error_naming_it(build, field: str
                                                                     ) -> None:
    """A list of pairs raised "'list' object has no attribute 'items'", a string in a
    Quantity "must be real number", an int too large for a float a bare OverflowError (a
    library user's pass, a verification pass).  A list of pairs is refused, not read: the
    message says to pass ``dict(pairs)``."""
    with pytest.raises(MeasurementError) as caught:
        build()
    assert caught.value.field == field
    if field in ("condition", "readings"):
        assert "dict(pairs)" in caught.value.message
