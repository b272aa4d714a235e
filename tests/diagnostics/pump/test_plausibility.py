"""A bench table must be possible with its displacement (:mod:`diagnostics.pump.plausibility`):
η_v = q/(D·ω) ≤ 1 and η_hm = Δp·D/T ≤ 1 (paper 000 eqs. 1 and 13), checked before a fit."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from diagnostics.pump import InstrumentNoise, iso4409_grid, parameterise, run_virtual_bench
from diagnostics.pump.bench import default_levels
from diagnostics.pump.data import BenchData
from sim.components.gear_pump_map import stand_in_pump
from sim.errors import InputError, MeasurementError


@pytest.fixture(scope="module")
def bench() -> BenchData:
    dp, w = iso4409_grid(*default_levels())
    return run_virtual_bench(stand_in_pump(), dp, w, (22.0, 60.0), noise=InstrumentNoise.none())


def test_the_true_displacement_and_the_data_pass(bench: BenchData) -> None:
    D = stand_in_pump().D
    eta_v = bench.q / (D * bench.omega)
    assert eta_v.max() <= 1.0  # the virtual pump only loses flow
    assert bench.torque is not None
    assert np.all(bench.dp * D / bench.torque <= 1.0)  # ... and only needs torque
    fitted = parameterise(bench, D=D)
    assert fitted.D == D
    assert float(np.min(fitted.fits["Cst"].values)) >= 0.0  # a leak, not a source


def test_a_displacement_in_the_wrong_unit_is_refused(bench: BenchData) -> None:
    cm3_rev = stand_in_pump().D * 2.0 * math.pi * 1e6  # the number a data sheet gives
    with pytest.raises(InputError) as e:
        parameterise(bench, D=cm3_rev)
    assert e.value.field == "D"
    assert "far larger than the pump delivers" in e.value.message
    toet = re.search(r"\(Toet\) is ([0-9.]+) cm³/rev", e.value.message)  # the way out
    assert toet is not None and float(toet.group(1)) == pytest.approx(cm3_rev, rel=0.01)


def test_a_displacement_the_flows_exceed_is_refused(bench: BenchData) -> None:
    D = stand_in_pump().D
    with pytest.raises(InputError) as e:  # every point would read η_v ≈ 1.1
        parameterise(bench, D=0.88 * D)
    assert e.value.field == "D"
    assert "smaller than the pump delivers" in e.value.message
    parameterise(bench, D=1.01 * D)  # a data-sheet value a little high is a fit's business


def test_torque_below_the_ideal_torque_is_refused(bench: BenchData) -> None:
    assert bench.torque is not None
    half = dataclasses.replace(bench, torque=0.5 * bench.torque)
    with pytest.raises(InputError) as e:  # Toet's D from the flows, then Δp·D/T ≈ 1.9
        parameterise(half)
    assert e.value.field == "T"
    assert "below the ideal torque" in e.value.message


@pytest.mark.parametrize(("slip", "change"), [
    ("l/min under [cm^3/s]", {"q": 1e-6 / 60e-6}),   # the flows (and Toet's D) ÷ 16.7
    ("MPa under [bar]", {"p_in": 0.1, "p_out": 0.1})])  # the pressures ÷ 10
def test_torque_far_above_the_ideal_torque_is_refused(bench: BenchData, slip: str,
                                                      change: dict[str, float]) -> None:
    """A real-data analyst's pass stored D = 2.06 cm³/rev for 34.35 (l/min under
    [cm^3/s]) and Δp ten times too small (MPa under [bar]): the file's own torque then
    reads a hydro-mechanical efficiency of 2-9 %, which no pump has."""
    assert bench.torque is not None
    D = stand_in_pump().D
    eta = float(np.median((bench.dp * D / bench.torque)[bench.dp >= 0.2 * bench.dp.max()]))
    assert 0.8 < eta <= 1.0   # the sound file: what pumps reach
    scaled = dataclasses.replace(bench, **{k: getattr(bench, k) * f for k, f in change.items()})
    with pytest.raises(InputError) as e:
        parameterise(scaled)
    assert e.value.field == "T", slip
    assert "hydro-mechanical efficiency of 0.0" in e.value.message
    assert "MPa under [bar]" in e.value.message


def test_a_negative_torque_reading_names_its_row(bench: BenchData) -> None:
    assert bench.torque is not None
    torque = bench.torque.copy()
    torque[3] = -5.0
    with pytest.raises(MeasurementError) as e:
        dataclasses.replace(bench, torque=torque)
    assert e.value.field == "torque"
    assert e.value.message.startswith("data row 4: shaft torque must be positive")


def test_torque_below_the_ideal_torque_names_what_else_makes_it(bench: BenchData) -> None:
    """A pump maker's pass: speeds in rev/s under [rpm] (the derived D 60× large) and a
    catalogue displacement 9 % high were both answered "check the torque column"."""
    slow = dataclasses.replace(bench, omega=bench.omega / 60.0)
    with pytest.raises(InputError) as e:
        parameterise(slow)
    assert e.value.field == "T" and "rev/s under an [rpm] header" in e.value.message
    D = stand_in_pump().D
    with pytest.raises(InputError) as e:
        parameterise(bench, D=1.09 * D)
    assert e.value.field == "T" and "the given displacement (too large" in e.value.message
    toet = re.search(r"\(Toet\) is ([0-9.]+) cm³/rev", e.value.message)
    assert toet is not None and float(toet.group(1)) == pytest.approx(D * 2e6 * math.pi,
                                                                      rel=0.01)


def test_the_case_drain_taken_as_the_delivered_flow_is_named(bench: BenchData) -> None:
    """Was "file.D: D must be > 0 and D_std ≥ 0": the leakage falls with speed where a
    delivery rises, so Toet's capacity comes out negative."""
    D = stand_in_pump().D
    drain = dataclasses.replace(bench, q=D * bench.omega - bench.q)
    with pytest.raises(InputError) as e:
        parameterise(drain)
    assert e.value.field == "q" and "case drain" in e.value.message


def test_a_plan_that_is_not_a_grid_is_told_to_give_its_displacement() -> None:
    """A Latin-hypercube bench (paper 001) was refused with "found 1 (is the plan a
    grid?)"; the message now counts what the data have and names the way through."""
    from diagnostics.pump import latin_hypercube_plan

    pump = stand_in_pump()
    dp, w = latin_hypercube_plan(30, (10e5, 250e5), (52.4, 261.8), seed=1, corner_points=4)
    lhs = run_virtual_bench(pump, dp, w, (40.0, 60.0), seed=2)
    with pytest.raises(InputError) as e:
        parameterise(lhs)
    assert e.value.field == "n" and "needs the displacement given" in e.value.message
    assert re.search(r"the data have \d+ pressure levels and \d+ speed levels", e.value.message)
    assert parameterise(lhs, D=pump.D).fits          # and with it, the coefficients


def test_outlet_below_inlet_names_its_row(bench: BenchData) -> None:
    p_out = bench.p_out.copy()
    p_out[5] = bench.p_in[5] - 1e4
    with pytest.raises(MeasurementError) as e:
        dataclasses.replace(bench, p_out=p_out)
    assert e.value.field == "p_out" and e.value.message.startswith("data row 6: outlet")


def test_a_negative_speed_is_quoted_in_rpm_too(bench: BenchData) -> None:
    omega = bench.omega.copy()
    omega[2] = -500.0 * math.pi / 30.0
    with pytest.raises(MeasurementError) as e:
        dataclasses.replace(bench, omega=omega)
    assert "(-500 rpm)" in e.value.message
