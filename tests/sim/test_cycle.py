"""Cycle runner: transient working + return phases, fault scenarios, and the steady fast path."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from sim.cycle import SUMMARY_UNITS, run_cycle
from sim.errors import InputError, ParameterError
from sim.rigs import Condition, reference_rig
from sim.scenarios import FAULTS, fault_overrides
from sim.steady import steady_cycle

LOADS = (2.1e3, 4.2e3, 6.3e3)


@pytest.fixture(scope="module")
def rig():
    return reference_rig()


def test_cycle_time_series_and_summary(rig):
    res = run_cycle(rig)
    ts = res.timeseries
    assert ts is not None
    assert {"t [s]", "x [m]", "v [m/s]", "P1 [Pa]", "Q_meter_B [m^3/s]"} <= set(ts.columns)
    assert list(ts["phase"].unique()) == ["working", "return"]
    assert np.all(np.diff(ts["t [s]"].to_numpy()) > 0)
    x = ts["x [m]"].to_numpy()
    # the piston stops at the stroke end (momentum carries it a few µm into the stop)
    assert x[0] == 0.0 and 0.5 <= x.max() < 0.5 + 1e-4 and abs(x[-1]) < 1e-9
    s = res.summary()
    assert s["working.duration [s]"] > 0 and s["return.duration [s]"] > 0
    assert s["velocity_ratio [-]"] == pytest.approx(
        s["working.speed [m/s]"] / s["return.speed [m/s]"])
    assert set(res.working.values) <= set(SUMMARY_UNITS)
    assert res.working.completed and res.return_.completed


def _close(a: float, b: float, rel: float, floor: float = 0.0) -> bool:
    return abs(a - b) <= rel * abs(b) + floor


@pytest.mark.parametrize(("fault", "load"), list(itertools.product(FAULTS, LOADS)))
def test_steady_path_agrees_with_transient_phase_averages(rig, fault, load):
    ov = fault_overrides(rig, fault)
    cond = Condition(load=load)
    tr = run_cycle(rig, ov, cond, timeseries=False)
    st = steady_cycle(rig, ov, cond)
    for phase_t, phase_s in ((tr.working, st.working), (tr.return_, st.return_)):
        assert _close(phase_s["speed"], phase_t["speed"], 0.005), (fault, load, phase_t.phase)
        for q in ("Q_meter_B", "Q_meter_C", "Q_valve_leak", "Q_pump_leak", "Q_relief"):
            assert _close(phase_s[q], phase_t[q], 0.005, 1e-9), (q, phase_t.phase)
        # the return-phase piston leakage is the difference of two near-equal terms
        # (Poiseuille vs Couette): compared against the working-phase leakage's size
        assert _close(phase_s["Q_cyl_leak"], phase_t["Q_cyl_leak"], 0.005,
                      0.005 * abs(tr.working["Q_cyl_leak"])), (fault, load, phase_t.phase)
    assert _close(st.velocity_ratio, tr.velocity_ratio, 0.005)


def test_faults_move_the_rig_the_expected_way(rig):
    base = steady_cycle(rig)
    seal = steady_cycle(rig, fault_overrides(rig, "worn_piston"))
    spool = steady_cycle(rig, fault_overrides(rig, "worn_spool"))
    pump = steady_cycle(rig, fault_overrides(rig, "worn_pump"))
    assert seal.working["Q_cyl_leak"] > 2 * base.working["Q_cyl_leak"]
    assert spool.working["Q_valve_leak"] > 4 * base.working["Q_valve_leak"]
    assert pump.working["Q_pump_leak"] == pytest.approx(3 * base.working["Q_pump_leak"], rel=0.02)
    for faulty in (seal, spool, pump):
        assert faulty.working["speed"] < base.working["speed"]
        assert faulty.velocity_ratio < base.velocity_ratio


def test_bad_overrides_and_conditions_are_refused(rig):
    with pytest.raises(ParameterError) as exc:
        run_cycle(rig, {"cylinder.cc": -1e-6})
    assert exc.value.field == "overrides.cylinder.cc"
    with pytest.raises(ParameterError) as exc:
        run_cycle(rig, {"cylinder.nope": 1.0})
    assert exc.value.field == "overrides.cylinder.nope"
    with pytest.raises(ParameterError) as exc:
        steady_cycle(rig, None, Condition(oil_temperature=400.0))
    assert exc.value.field == "condition.oil_temperature"
    with pytest.raises(InputError):
        fault_overrides(rig, "broken_everything")


def test_temperature_changes_leakage_through_viscosity(rig):
    cold = steady_cycle(rig, None, Condition(oil_temperature=25.0))
    hot = steady_cycle(rig, None, Condition(oil_temperature=60.0))
    assert hot.working["Q_valve_leak"] > 1.5 * cold.working["Q_valve_leak"]
    assert hot.velocity_ratio < cold.velocity_ratio


def test_the_summary_speed_is_the_encoders_reading_and_the_steady_speed() -> None:
    """The summary gave stroke over duration, which counts the oil compressed before the
    piston moves (0.1-0.5 % off the steady speed); a rig author's commissioning, fed those
    speeds, moved a seal land 8 % to absorb it.  Now the slope over 10-90 % of the travel,
    as a measured cycle is read: the steady model's speed to 1e-5 at every load."""
    rig = reference_rig()
    for load in (2100.0, 6300.0):
        cond = Condition(load=load, oil_temperature=40.0)
        res, steady = run_cycle(rig, {}, cond, timeseries=False), steady_cycle(rig, {}, cond)
        for ph, model in ((res.working, steady.working), (res.return_, steady.return_)):
            assert ph["speed"] == pytest.approx(model["speed"], rel=1e-5)
            travel = rig.base["cylinder.stroke"]
            assert travel / ph["duration"] != pytest.approx(model["speed"], rel=4e-4)


@pytest.mark.parametrize("stroke", [0.25, 0.8])
def test_a_stroke_override_is_the_stroke_the_cycle_runs(stroke: float) -> None:
    """A 0.25 m stroke override ran to 45 s of "stall" on the piston's stop (the end event
    at the stored 0.5 m), a 0.8 m one stopped at 0.5 m, and the steady path kept the stored
    stroke's duration (a modelling engineer's pass): the stroke is the override's."""
    rig = reference_rig()
    overrides = {"cylinder.stroke": stroke}
    res = run_cycle(rig, overrides, method="rodas4", sample_rate=200.0)
    steady = steady_cycle(rig, overrides)
    assert res.working.completed and res.return_.completed
    assert res.timeseries is not None
    assert res.timeseries["x [m]"].max() == pytest.approx(stroke, abs=2e-3)
    for ph, model in ((res.working, steady.working), (res.return_, steady.return_)):
        assert model["duration"] == pytest.approx(stroke / model["speed"])
        assert ph["duration"] == pytest.approx(model["duration"], rel=0.01)
        assert ph["speed"] == pytest.approx(model["speed"], rel=1e-4)


def test_the_summary_does_not_depend_on_the_tables_sample_rate() -> None:
    """At 1 Hz the phase averages were those of five samples (meter B 140 σ off, the
    return's four times the pump's flow) and the error estimate 3e-5 σ (a modelling
    engineer's pass): the summary is averaged on at least 1 kHz, the table keeps its rate."""
    rig = reference_rig()
    cond = Condition(load=4200.0, oil_temperature=40.0)
    overrides = fault_overrides(rig, "worn_spool")
    coarse = run_cycle(rig, overrides, cond, method="rodas4", sample_rate=1.0)
    fine = run_cycle(rig, overrides, cond, method="rodas4", sample_rate=1000.0)
    for a, b in ((coarse.working, fine.working), (coarse.return_, fine.return_)):
        for key in ("P_pump", "Q_meter_B", "Q_meter_C", "speed", "duration"):
            assert a[key] == pytest.approx(b[key], rel=1e-6), key
    assert coarse.timeseries is not None
    steps = np.diff(coarse.timeseries["t [s]"].to_numpy())
    assert np.allclose(steps, 1.0)                      # the table at the rate asked for
    assert max(coarse.solver.error_sigma.values()) == pytest.approx(
        max(fine.solver.error_sigma.values()), rel=0.5)


def test_a_long_stroke_runs_though_its_stall_guard_passes_the_time_limit() -> None:
    """A 3 m press with an 80 s cycle was refused whole: its stall guard, 20× each stroke's
    time at the pump's flow (1,248 s), counted as the cycle's length against the 600 s
    limit (a modelling engineer's pass).  The guard stops at the limit instead."""
    rig = reference_rig()
    overrides = {"cylinder.stroke": 20.0}                  # ~97 s a stroke, guard ~1,940 s
    res = run_cycle(rig, overrides, method="rodas4", sample_rate=10.0)
    steady = steady_cycle(rig, overrides)
    assert res.working.completed and res.return_.completed
    assert res.working["duration"] == pytest.approx(steady.working["duration"], rel=0.01)


def test_a_creep_slower_than_the_stall_guard_is_no_completed_stroke_on_either_path() -> None:
    """At 150 °C the 83 µm piston leaks most of the pump's flow: a 2.9 h creep, called a
    stall by the transient and a completed stroke by the steady path (a modelling
    engineer's pass)."""
    rig = reference_rig()
    cond = Condition(load=2100.0, oil_temperature=150.0)
    steady = steady_cycle(rig, {}, cond)
    transient = run_cycle(rig, {}, cond, method="rodas4", timeseries=False)
    assert not steady.working.completed and not transient.working.completed
    assert steady.working["speed"] == pytest.approx(transient.working["speed"], rel=0.1)
    assert steady_cycle(rig, {}, Condition(load=2100.0, oil_temperature=40.0)).working.completed


def test_a_differential_cylinders_stall_guard_is_the_stroke_time_of_the_chamber_filled() -> None:
    """The guard took min(A1, A2) in both phases: a 100/90 cylinder (5.3:1) working at 22 %
    of its geometric speed was cut as "stalled" 0.42 m into its 0.5 m stroke (an edge
    pass).  Working, A1 is filled; returning, A2; on either path the stroke completes."""
    from sim.cycle import phase_params, stall_guard

    rig = reference_rig()
    overrides = {"cylinder.bore": 0.1, "cylinder.rod1": 0.0, "cylinder.rod2": 0.09}
    cond = Condition(load=54500.0, oil_temperature=40.0)
    work, back = (phase_params(rig, phase, overrides, cond) for phase in ("working", "return"))
    v = rig.values()
    q = v["pump.speed"] * v["pump.Vp"]
    a1, a2 = np.pi * 0.1**2 / 4, np.pi * (0.1**2 - 0.09**2) / 4
    assert stall_guard(rig, work, phase="working") == pytest.approx(20 * 0.5 * a1 / q, rel=1e-9)
    assert stall_guard(rig, back, phase="return") == pytest.approx(20 * 0.5 * a2 / q, rel=1e-9)
    steady = steady_cycle(rig, overrides, cond)
    assert steady.working["speed"] < 0.25 * q / a1  # a slow stroke, well past min(A1, A2)'s
    transient = run_cycle(rig, overrides, cond, method="rodas4", timeseries=False)
    assert steady.working.completed and transient.working.completed
    assert transient.working["speed"] == pytest.approx(steady.working["speed"], rel=0.05)


@pytest.mark.parametrize("stroke", [0.2, 0.1, 0.05])
def test_a_short_stroke_after_the_nominal_one_has_its_steady_point(stroke: float) -> None:
    """The cached operating point of the rig kept the nominal stroke's mid position
    (0.25 m): a 0.2 m stroke after it met its own end stop there and had "no steady
    operating point", where it ran first (an edge pass)."""
    rig = reference_rig()
    nominal = steady_cycle(rig)
    short = steady_cycle(rig, {"cylinder.stroke": stroke})
    assert short.working.completed and short.return_.completed
    assert short.working["speed"] == pytest.approx(nominal.working["speed"], rel=1e-6)
    assert short.working["duration"] == pytest.approx(
        nominal.working["duration"] * stroke / 0.5, rel=1e-6)
    # and back: the long stroke after the short one
    assert steady_cycle(rig).working["speed"] == pytest.approx(nominal.working["speed"],
                                                              rel=1e-9)


def test_a_stroke_held_at_its_stop_is_a_completed_stroke() -> None:
    """With ``hold`` the working phase ends at ``t_max`` only: a stroke that reached its
    stop in 2.42 s, held to 5 s, read as a stall at 0.100 m/s with a velocity ratio of
    0.456 for 0.940 (a library user's pass).  It is the same stroke as the one switched at
    its stop, its dwell the phase's duration."""
    rig = reference_rig()
    switched = run_cycle(rig, method="rodas4", timeseries=False)
    held = run_cycle(rig, method="rodas4", timeseries=False, t_max=5.0, hold=True)
    assert held.working.completed and held.return_.completed
    assert held.working["speed"] == pytest.approx(switched.working["speed"], rel=1e-4)
    assert held.velocity_ratio == pytest.approx(switched.velocity_ratio, rel=1e-4)
    assert held.working["duration"] == pytest.approx(5.0)
    assert not any("did not reach its end" in n for n in held.notes())
    # a piston that cannot reach its stop within t_max is no completed stroke, held or not
    short = run_cycle(rig, method="rodas4", timeseries=False, t_max=1.0, hold=True)
    assert not short.working.completed


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"rtol": 1.0}, "rtol"), ({"rtol": -1e-3}, "rtol"), ({"rtol": float("nan")}, "rtol"),
    ({"t_max": 0.0}, "t_max"), ({"t_max": -1.0}, "t_max"), ({"t_max": float("nan")}, "t_max")])
def test_a_tolerance_or_time_limit_that_means_nothing_is_refused(kwargs: dict, field: str
                                                                 ) -> None:
    """rtol 1 returned a return speed of 8.5 m/s and P1 483 bar, t_max 0 or NaN an all-zero
    cycle (a library user's pass)."""
    with pytest.raises(ParameterError) as caught:
        run_cycle(reference_rig(), method="rodas4", timeseries=False, **kwargs)
    assert caught.value.field == field


@pytest.mark.parametrize(("call", "error", "field"), [
    (lambda rig: run_cycle(rig, method="rodas4", sample_rate="1000"), ParameterError,
     "sample_rate"),
    (lambda rig: run_cycle(rig, rtol="1e-3"), ParameterError, "rtol"),
    (lambda rig: run_cycle(None), InputError, "rig"),
    (lambda rig: steady_cycle(rig, {1: 6e-5}), ParameterError, "overrides"),
    (lambda rig: steady_cycle(rig, {"cylinder.cc": 10**400}), ParameterError,
     "overrides.cylinder.cc"),
    (lambda rig: steady_cycle(rig, None, Condition(load=10**400)), ParameterError,
     "condition.force"),
    (lambda rig: steady_cycle({"name": "press"}), InputError, "rig"),
])
def test_an_argument_of_the_wrong_type_is_the_trees_error_naming_it(rig, call, error,
                                                                   field: str) -> None:
    """A string sample rate, a key 1 in the overrides or an int too large for a float
    raised a bare TypeError, AttributeError or OverflowError (a library user's pass, a
    verification pass)."""
    with pytest.raises(error) as caught:
        call(rig)
    assert caught.value.field == field
    assert field.rpartition(".")[2] in str(caught.value)


def test_an_unknown_steady_phase_names_the_phases(rig) -> None:
    """"work" raised a bare ValueError (a library user's pass)."""
    from sim.steady import steady_phase

    with pytest.raises(InputError) as caught:
        steady_phase(rig, "work")
    assert caught.value.field == "phase" and "working, return" in caught.value.message
