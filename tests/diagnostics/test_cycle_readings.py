"""A measured cycle read as a record (diagnostics.cycle_readings): the simulator's own
phase readings come back from its exported series, the speeds are the steady model's, a
stalled stroke is read as the accuracy study reads it, and a cycle that cannot be read is
refused naming why."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
import pytest

from benchmarks.accuracy_cases import transient_readings
from diagnostics.cycle_readings import (
    COMPLETED_SHARE,
    cycle_readings,
    phases_from_position,
    reversal_delay,
)
from diagnostics.diagnose import diagnose
from diagnostics.quantity import DEFAULT_INSTRUMENTS
from diagnostics.signatures import evaluator
from diagnostics.timeseries import SeriesRecord, read_series, series_from_frame
from sim.cycle import run_cycle
from sim.errors import InputError
from sim.rigs import Condition, reference_rig

RIG = reference_rig()
STROKE = RIG.base["cylinder.stroke"]
WORN_SPOOL = {"valve.cv": 60e-6}
LOAD, TEMP = 4200.0, 40.0


def _export(overrides: dict[str, float], load: float, temp: float, **kw: Any) -> Any:
    """The cycle as ``/simulate`` exports it (1 kHz grid, noise-accurate RODAS4) with its
    condition as constant columns, and the run."""
    res = run_cycle(RIG, overrides, Condition(load=load, oil_temperature=temp),
                    method="rodas4", sample_rate=1000.0, **kw)
    frame = res.timeseries.assign(**{"load [N]": load, "oil_temperature [degC]": temp})
    return frame, res


@pytest.fixture(scope="module")
def worn_spool() -> Any:
    return _export(WORN_SPOOL, LOAD, TEMP)


def test_the_exported_cycle_reads_back_as_the_simulators_phase_summary(worn_spool: Any,
                                                                       tmp_path: Any) -> None:
    frame, res = worn_spool
    path = tmp_path / "cycle.csv"
    frame.to_csv(path, index=False)
    [series] = read_series(path)  # the one import path, through a file
    read = cycle_readings(series, STROKE)
    w = res.working.values
    expected = {"pump_pressure": w["P_pump"], "p1": w["P1"], "p2": w["P2"],
                "flow_B": w["Q_meter_B"], "flow_C": w["Q_meter_C"]}
    for name, value in expected.items():  # the same window and rule, on the same samples
        assert read.readings[name] == pytest.approx(value, rel=1e-9, abs=1e-12), name
    # no pump flow meter in the export: meter B + relief flow is not a second reading
    assert "pump_flow" not in read.readings
    assert read.condition == {"load_force": LOAD, "oil_temperature": TEMP}
    assert [p.completed for p in read.phases] == [True, True] and read.notes == ()
    # the steady stroke's speed is the steady model's, and so is the summary's (which was
    # stroke/duration, 0.1 % lower, before 2026-11-30)
    model = evaluator(RIG, Condition(load=LOAD, oil_temperature=TEMP))
    values = [WORN_SPOOL.get(n, RIG.base[n]) for n in model.names]
    v_work, v_return = model.vector(values, ("speed_work", "speed_return"))
    u = DEFAULT_INSTRUMENTS["speed_work"].relative_bound / np.sqrt(3.0)
    assert abs(read.readings["speed_work"] / v_work - 1.0) < 0.01 * u
    assert abs(read.readings["speed_return"] / v_return - 1.0) < 0.01 * u
    assert abs(res.working.values["speed"] / v_work - 1.0) < 0.01 * u
    stroke_over_duration = RIG.base["cylinder.stroke"] / res.working.values["duration"]
    assert abs(stroke_over_duration / v_work - 1.0) > 0.2 * u


def test_a_read_cycle_is_diagnosed_as_its_fault(worn_spool: Any) -> None:
    frame, _ = worn_spool
    [series] = series_from_frame(frame)
    result = diagnose(RIG, [cycle_readings(series, STROKE).record("reference")])
    top = result.hypotheses[0]
    assert top.name == "valve" and top.probability > 0.5
    [cv] = top.parameters
    assert cv.low <= WORN_SPOOL["valve.cv"] <= cv.high


def test_the_speed_channel_stands_in_for_the_position(worn_spool: Any) -> None:
    frame, _ = worn_spool
    [with_x] = series_from_frame(frame)
    [with_v] = series_from_frame(frame.drop(columns=["x [m]"]))
    a, b = cycle_readings(with_x, STROKE), cycle_readings(with_v, STROKE)
    for name in ("speed_work", "speed_return", "p1", "flow_C"):
        assert b.readings[name] == pytest.approx(a.readings[name], rel=1e-4), name


def test_a_noisy_position_still_gives_the_steady_speed(worn_spool: Any) -> None:
    """A 0.1 mm rms encoder noise: the slope over the middle of the stroke stays within a
    tenth of the encoder's class, where the end points' difference would not be bound."""
    frame, _ = worn_spool
    rng = np.random.default_rng(3)
    noisy = frame.assign(**{"x [m]": frame["x [m]"] + rng.normal(0.0, 1e-4, len(frame))})
    [clean], [rough] = series_from_frame(frame), series_from_frame(noisy)
    a, b = cycle_readings(clean, STROKE), cycle_readings(rough, STROKE)
    for name in ("speed_work", "speed_return"):
        assert abs(b.readings[name] / a.readings[name] - 1.0) < 5e-4, name


def test_a_stalled_working_stroke_is_read_as_the_accuracy_study_reads_it() -> None:
    """A worn seal under a heavy hot load: the working piston stops short of its stroke;
    its settled state is read over the last half of the phase, the return stroke gives no
    speed, and the notes say so."""
    overrides, load, temp = {"cylinder.cc": 4e-4}, 6300.0, 60.0
    frame, res = _export(overrides, load, temp)
    assert not res.working.completed
    [series] = series_from_frame(frame)
    read = cycle_readings(series, STROKE)
    assert read.phases[0].completed is False
    assert read.phases[0].travel < COMPLETED_SHARE * STROKE
    assert "speed_return" not in read.readings
    assert any("stalled" in n for n in read.notes)
    bench = transient_readings(RIG, overrides, load, temp)  # the same rules on ROS2 steps
    for name in ("pump_pressure", "p1", "p2", "flow_B", "flow_C"):
        assert read.readings[name] == pytest.approx(bench.values[name], rel=2e-3), name


def _series(frame: pd.DataFrame) -> SeriesRecord:
    return series_from_frame(frame)[0]


@pytest.mark.parametrize(("change", "field"), [
    (lambda f: f.drop(columns=["phase"]).assign(**{"x [m]": 0.0, "v [m/s]": 0.0}), "phase"),
    (lambda f: pd.concat([f, f.assign(**{"t [s]": f["t [s]"] + 6.0})]).drop(columns=["phase"]),
     "phase"),
    (lambda f: f.drop(columns=["x [m]", "v [m/s]"]), "x"),
    (lambda f: f.assign(phase="dwell"), "phase"),
])
def test_a_cycle_that_cannot_be_read_is_refused_naming_why(worn_spool: Any, change: Any,
                                                           field: str) -> None:
    frame, _ = worn_spool
    with pytest.raises(InputError) as err:
        cycle_readings(_series(change(frame)), STROKE)
    assert err.value.field == field


def test_the_condition_is_the_series_unless_stated(worn_spool: Any) -> None:
    frame, _ = worn_spool
    bare = _series(frame.drop(columns=["oil_temperature [degC]"]))
    with pytest.raises(InputError) as err:
        cycle_readings(bare, STROKE).record("reference")
    assert err.value.field == "condition.oil_temperature"
    stated = cycle_readings(bare, STROKE, {"oil_temperature": 45.0})
    assert stated.record("reference").condition.oil_temperature.value == 45.0
    with pytest.raises(InputError) as err:
        cycle_readings(bare, STROKE, {"temperature": 45.0})
    assert err.value.field == "condition.temperature"
    both = _series(frame.assign(**{"back_pressure [Pa]": 1e6}))
    with pytest.raises(InputError) as err:
        cycle_readings(both, STROKE)
    assert err.value.field == "condition.back_pressure"
    # a logged temperature that drifts is averaged over the working stroke's window
    t = frame["t [s]"].to_numpy()
    drifting = _series(frame.assign(**{"oil_temperature [degC]": 40.0 + t}))
    read = cycle_readings(drifting, STROKE)
    lo, hi = read.phases[0].window
    assert read.condition["oil_temperature"] == pytest.approx(40.0 + 0.5 * (lo + hi), rel=1e-6)


def test_read_cycles_agree_with_the_steady_model_at_the_truth() -> None:
    """40 cycles of random wear (seal, spool or pump, within their worn ranges), load and
    oil temperature: every reading a cycle gives lies within a quarter of its instrument's
    σ of the steady model at the true parameters (measured: ≤ 0.15 σ, the largest p2 of a
    healthy rig, whose hose oscillation has not quite died in the window), creeping
    strokes included; a held stroke gives no speed and says so."""
    rng = np.random.default_rng(1)
    held = 0
    for _ in range(40):
        overrides = {}
        which = int(rng.integers(0, 4))
        if which == 1:
            overrides["valve.cv"] = RIG.base["valve.cv"] * rng.uniform(1.1, 3.0)
        elif which == 2:
            overrides["cylinder.cc"] = RIG.base["cylinder.cc"] * rng.uniform(1.1, 2.5)
        elif which == 3:
            overrides["pump.Rlp"] = RIG.base["pump.Rlp"] / rng.uniform(1.3, 10.0)
        load, temp = float(rng.uniform(1e3, 6e3)), float(rng.uniform(30.0, 60.0))
        frame, _ = _export(overrides, load, temp)
        read = cycle_readings(_series(frame), STROKE)
        model = evaluator(RIG, Condition(load=load, oil_temperature=temp))
        names = tuple(read.readings)
        predicted = model.vector([overrides.get(n, RIG.base[n]) for n in model.names], names)
        for name, p in zip(names, predicted, strict=True):
            inst = DEFAULT_INSTRUMENTS[name]
            u = (inst.relative_bound * abs(p) + inst.absolute_bound) / np.sqrt(3.0)
            assert abs(read.readings[name] - p) < 0.25 * u, (overrides, load, temp, name)
        if "speed_work" not in read.readings:   # held: the model predicts speed 0
            held += 1
            assert not read.phases[0].completed
            assert any("held on its end stop" in n for n in read.notes)
    assert held >= 1   # the draws include a working stroke the load holds


def test_a_held_piston_with_a_noisy_position_gives_no_speed() -> None:
    """A measured held stroke: its position sensor's noise (5 µm rms) is no creep speed —
    a relative-class reading of it would claim micrometres per minute to 0.3 %."""
    frame, res = _export({"cylinder.cc": 4e-4}, 6300.0, 60.0)
    assert not res.working.completed
    rng = np.random.default_rng(7)
    noisy = frame.assign(**{"x [m]": frame["x [m]"] + rng.normal(0.0, 5e-6, len(frame))})
    read = cycle_readings(_series(noisy), STROKE)
    assert "speed_work" not in read.readings and "speed_return" not in read.readings
    assert read.record("reference").speed("work") is None


@pytest.mark.parametrize(("rate", "extra"), [(20.0, {}), (1000.0, {"t_max": 4.6, "hold": True})])
def test_coarse_sampling_and_a_dwell_read_as_the_steady_stroke(rate: float,
                                                               extra: dict[str, Any]) -> None:
    """At 20 Hz a stroke's end stop falls up to one sample (11 mm) after its last sample:
    still a completed stroke, not a stall; a dwell held at the end stop after the stroke
    (a timer-switched test) is outside the steady window.  Both read the steady model's
    readings within 0.01 σ."""
    res = run_cycle(RIG, WORN_SPOOL, Condition(load=LOAD, oil_temperature=TEMP),
                    method="rodas4", sample_rate=rate, **extra)
    frame = res.timeseries.assign(**{"load [N]": LOAD, "oil_temperature [degC]": TEMP})
    read = cycle_readings(_series(frame), STROKE)
    assert [p.completed for p in read.phases] == [True, True] and read.notes == ()
    model = evaluator(RIG, Condition(load=LOAD, oil_temperature=TEMP))
    names = tuple(read.readings)
    predicted = model.vector([WORN_SPOOL.get(n, RIG.base[n]) for n in model.names], names)
    for name, p in zip(names, predicted, strict=True):
        u = DEFAULT_INSTRUMENTS[name].relative_bound * abs(p) / np.sqrt(3.0)
        assert abs(read.readings[name] - p) < 0.01 * u, name


def test_a_loggers_table_with_a_spool_command_reads_as_the_export(worn_spool: Any) -> None:
    """A data logger's table: its own column names through a column map, pressures in bar,
    the position in mm, the spool command N = +1 / −1 (paper 002) as its phase column —
    the same readings as the export's."""
    frame, _ = worn_spool
    log = pd.DataFrame({
        "time": frame["t [s]"], "N": np.where(frame["phase"] == "working", 1, -1),
        "pos": 1e3 * frame["x [m]"], "PT1": frame["P1 [Pa]"] / 1e5,
        "PT2": frame["P2 [Pa]"] / 1e5, "FT_C": 6e4 * frame["Q_meter_C [m^3/s]"]})
    [series] = read_series(log, column_map={
        "time": ("t", "s"), "N": ("phase", "-"), "pos": ("x", "mm"), "PT1": ("P1", "bar"),
        "PT2": ("P2", "bar"), "FT_C": ("Q_meter_C", "L/min")})
    assert set(series.phase.tolist()) == {"working", "return"}
    read = cycle_readings(series, STROKE, {"oil_temperature": TEMP, "load_force": LOAD})
    export = cycle_readings(_series(frame), STROKE)
    assert set(read.readings) == {"p1", "p2", "flow_C", "speed_work", "speed_return"}
    for name, value in read.readings.items():
        assert value == pytest.approx(export.readings[name], rel=1e-9), name


@pytest.mark.parametrize("extra", [{}, {"t_max": 4.6, "hold": True}])
def test_a_cycle_logged_without_phases_reads_them_off_the_position(extra: dict[str, Any]
                                                                  ) -> None:
    """A logger that records the position but not the spool command: working up to the
    piston's reversal (after a dwell at the stop, if any), return after it — the same
    readings as with the phase column, and a note that says how the phases were found."""
    res = run_cycle(RIG, WORN_SPOOL, Condition(load=LOAD, oil_temperature=TEMP),
                    method="rodas4", sample_rate=1000.0, **extra)
    frame = res.timeseries.assign(**{"load [N]": LOAD, "oil_temperature [degC]": TEMP})
    labelled = cycle_readings(_series(frame), STROKE)
    unlabelled = cycle_readings(_series(frame.drop(columns=["phase"])), STROKE)
    assert [p.completed for p in unlabelled.phases] == [True, True]
    for name, value in labelled.readings.items():
        assert unlabelled.readings[name] == pytest.approx(value, rel=1e-8), name
    [note] = unlabelled.notes
    switch = float(frame[frame["phase"] == "working"]["t [s]"].iloc[-1])
    assert "no phase column" in note and abs(float(note.split("t = ")[1].split()[0]) - switch) < 0.005


def test_the_reversal_delay_is_where_the_position_starts_the_return() -> None:
    """The return read off the position starts at the piston's reversal: on the model's
    cycle, the delay after the valve's switch is the time to the first sample
    :func:`phases_from_position` labels return — a few ms, the chambers reversing the force
    before the piston turns — and a cycle without a return has none."""
    frame, _ = _export(WORN_SPOOL, LOAD, TEMP)
    t = frame["t [s]"].to_numpy(dtype=float)
    x = frame["x [m]"].to_numpy(dtype=float)
    phase = frame["phase"].to_numpy(dtype=str)
    delay = reversal_delay(t, x, phase, STROKE)
    read = phases_from_position(_series(frame.drop(columns=["phase"])), x, STROKE)
    switch = t[np.flatnonzero(phase == "return")[0]]
    assert t[np.flatnonzero(read == "return")[0]] == pytest.approx(switch + delay, abs=1e-12)
    assert 0.0 < delay < 0.02
    assert reversal_delay(t, x, np.full(t.size, "working"), STROKE) == 0.0


def test_a_channel_the_cycle_does_not_read_is_noted_with_the_nearest_name(worn_spool: Any
                                                                         ) -> None:
    """A column map's ``P_pmup`` and ``Q_meter_b`` dropped the pump pressure and meter B
    without a word, and the worn spool's diagnosis fell from p 0.89 to 0.54 (a library
    user's pass): the readings say which channels they did not read, and the names meant.
    The model's other outputs, which the export carries, are no note."""
    frame, _ = worn_spool
    typo = frame.rename(columns={"P_pump [Pa]": "P_pmup [Pa]",
                                 "Q_meter_B [m^3/s]": "Q_meter_b [m^3/s]"})
    read = cycle_readings(_series(typo), STROKE)
    assert "pump_pressure" not in read.readings and "flow_B" not in read.readings
    [note] = [n for n in read.notes if "not channels" in n]
    assert note.startswith("channel(s) P_pmup, Q_meter_b are not channels of the rig's model")
    assert "did you mean 'P_pump' for 'P_pmup', 'Q_meter_B' for 'Q_meter_b'?" in note
    assert cycle_readings(_series(frame), STROKE).notes == ()
    # the rig's own channels, given: an effect's output is known, an unknown one still noted
    known = cycle_readings(_series(typo), STROKE, model_channels=[*RIG.channels(), "P_pmup"])
    assert any("Q_meter_b" in n and "P_pmup," not in n for n in known.notes)
