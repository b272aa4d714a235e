"""Pump slip coefficient Cs from field points (paper 000 eqs. 6-7)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from diagnostics.measurement import MeasurementRecord, OperatingCondition, Quantity
from diagnostics.slip import slip_coefficient, slip_coefficient_two_temperatures
from sim.components.gear_pump import CoefficientSurface
from sim.components.gear_pump_map import stand_in_pump
from sim.errors import MeasurementError

PUMP = stand_in_pump()
RPM = 2 * math.pi / 60


def field_point(dp: float, omega: float, theta: float, *, pump=PUMP,
                flow_name: str = "pump_flow") -> MeasurementRecord:
    """The reading the pump model (eq. 6) gives, with paper 000's instrument classes."""
    q = float(pump.flow(dp, omega, theta))
    cond = OperatingCondition.from_readings({"oil_temperature": theta, "back_pressure": 0.0,
                                             "pump_speed": omega})
    return MeasurementRecord.from_readings("drill-1", cond, {flow_name: q, "pump_pressure": dp})


@pytest.mark.parametrize(("dp", "rpm", "theta"), [(90e5, 1030, 40.0), (135e5, 1467, 55.0),
                                                  (220e5, 1961, 30.0), (20e5, 2400, 50.0)])
def test_round_trip_recovers_the_map_value(dp: float, rpm: float, theta: float) -> None:
    est = slip_coefficient(field_point(dp, rpm * RPM, theta), PUMP)
    truth = float(PUMP.Cs(dp, rpm * RPM))  # negative at 20 bar / 2400 rpm (Couette drag)
    assert est.value == pytest.approx(truth, rel=1e-9)
    assert est.derived["Cs_reference"] == pytest.approx(truth, rel=1e-12)
    assert est.low <= est.value <= est.high


def test_worn_pump_shows_a_larger_slip_coefficient() -> None:
    dp, omega, theta = 135e5, 1467 * RPM, 50.0
    healthy = float(PUMP.Cs(dp, omega))
    worn = replace(PUMP, Cs=CoefficientSurface.constant(3.0 * healthy))
    est = slip_coefficient(field_point(dp, omega, theta, pump=worn), PUMP)
    assert est.value == pytest.approx(3.0 * healthy, rel=1e-9)
    assert est.value / est.derived["Cs_reference"] == pytest.approx(3.0, rel=1e-9)
    assert est.derived["eta_v"] < float(PUMP.flow(dp, omega, theta)) / (PUMP.D * omega)


def test_meter_b_stands_in_for_the_pump_flow_with_a_note() -> None:
    est = slip_coefficient(field_point(135e5, 1467 * RPM, 50.0, flow_name="flow_B"), PUMP)
    assert est.value == pytest.approx(float(PUMP.Cs(135e5, 1467 * RPM)), rel=1e-9)
    assert any("meter B" in n for n in est.notes)


def test_uncertainty_is_dominated_by_the_flowmeter_and_methods_agree() -> None:
    rec = field_point(200e5, 1500 * RPM, 50.0)
    d = slip_coefficient(rec, PUMP, method="delta")
    # the laminar slip is ~1 % of D·ω here: ±1 % flowmeter and tachometer leave Cs poorly
    # determined by a single field point, and flow and speed share almost all of u²
    assert d.relative > 0.3
    assert d.contributions["flow"] + d.contributions["omega"] > 0.99
    # Cs is linear in flow and speed, so the first order is exact in them
    m = slip_coefficient(rec, PUMP, method="monte-carlo", n=40_000,
                         rng=np.random.default_rng(7))
    assert m.u == pytest.approx(d.u, rel=0.05)


def test_two_temperature_method_recovers_cs_without_cst() -> None:
    dp, omega = 135e5, 1467 * RPM
    cold, warm = field_point(dp, omega, 22.0), field_point(dp, omega, 60.0)
    est = slip_coefficient_two_temperatures(cold, warm, PUMP.D, fluid=PUMP.fluid)
    assert est.value == pytest.approx(float(PUMP.Cs(dp, omega)), rel=1e-9)
    assert est.derived["mu1"] > est.derived["mu2"]


def test_two_temperature_method_refuses_unequal_conditions() -> None:
    a = field_point(135e5, 1467 * RPM, 22.0)
    with pytest.raises(MeasurementError) as err:
        slip_coefficient_two_temperatures(a, field_point(160e5, 1467 * RPM, 60.0), PUMP.D)
    assert err.value.field == "pump_pressure"
    with pytest.raises(MeasurementError) as err:
        slip_coefficient_two_temperatures(a, field_point(135e5, 1467 * RPM, 22.5), PUMP.D)
    assert err.value.field == "condition.oil_temperature"


def test_missing_speed_or_pressure_is_named() -> None:
    cond = OperatingCondition.from_readings({"oil_temperature": 40.0, "back_pressure": 0.0})
    rec = MeasurementRecord("r", cond, pump_flow=Quantity(3e-4, 1e-6),
                            pump_pressure=Quantity(1e7, 1e4))
    with pytest.raises(MeasurementError) as err:
        slip_coefficient(rec, PUMP)
    assert err.value.field == "condition.pump_speed"
    with pytest.raises(MeasurementError) as err:
        slip_coefficient(replace(rec, pump_pressure=None), PUMP)
    assert err.value.field == "pump_pressure"
