"""Pump slip coefficient Cs from field points (paper 000 eqs. 6-7)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from diagnostics.measurement import MeasurementRecord, OperatingCondition, Quantity
from diagnostics.slip import (
    rig_slip_coefficient,
    slip_coefficient,
    slip_coefficient_two_temperatures,
)
from sim.components.gear_pump import CoefficientSurface, flow_losses
from sim.components.gear_pump_map import stand_in_pump
from sim.errors import MeasurementError
from sim.rigs import reference_rig

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


@pytest.mark.parametrize("speed_ratio", [1.004, 0.996])
def test_two_temperature_method_removes_a_small_speed_difference(speed_ratio: float) -> None:
    # eq. 7 with the warm point at a slightly different speed (inside the ±1 % tachometer,
    # so the two points still count as one condition): the flow difference then holds
    # D·(ω₁ − ω₂) besides the viscosity term, ~40 % of it here.  Constant Cs and Cst and a
    # stiff oil leave only the two, so the corrected difference gives Cs back exactly;
    # without the correction, or with it added, Cs is off by about half (a mutation review)
    dp, omega = 135e5, 1467 * RPM
    cs = float(PUMP.Cs(dp, omega))
    pump = replace(PUMP, Cs=CoefficientSurface.constant(cs),
                   Cst=CoefficientSurface.constant(float(PUMP.Cst(dp, omega))), beta_ef=1e20)
    cold = field_point(dp, omega, 22.0, pump=pump)
    warm = field_point(dp, speed_ratio * omega, 60.0, pump=pump)
    dq_speed = pump.D * omega * abs(speed_ratio - 1.0)
    dq_slip = abs(float(pump.flow(dp, omega, 22.0)) - float(pump.flow(dp, omega, 60.0)))
    assert dq_speed > 0.2 * dq_slip  # the correction matters at this speed difference
    est = slip_coefficient_two_temperatures(cold, warm, pump.D, fluid=pump.fluid)
    assert est.value == pytest.approx(cs, rel=1e-9)


def test_derived_slip_flow_and_efficiency_close_the_flow_balance() -> None:
    # eq. 6 is a balance: geometric flow D·ω = delivered flow + laminar, turbulent and
    # compressibility losses.  The estimate's laminar slip flow must be the forward
    # model's laminar loss, and its ηv the delivered share of D·ω, 1 − ΣQ_loss/(D·ω)
    # (a mutation review: Q_s multiplied by μ, and ηv without ω, went unnoticed)
    dp, omega, theta = 135e5, 1467 * RPM, 50.0
    est = slip_coefficient(field_point(dp, omega, theta), PUMP)
    qs, qst, qc = (float(x) for x in PUMP.losses(dp, omega, theta))
    assert est.derived["Q_s"] == pytest.approx(qs, rel=1e-9)
    assert est.derived["eta_v"] == pytest.approx(1.0 - (qs + qst + qc) / (PUMP.D * omega),
                                                 rel=1e-12)
    assert est.derived["mu"] == pytest.approx(PUMP.fluid.dynamic_viscosity(theta), rel=1e-12)


@pytest.mark.parametrize("theta", [20.0, 50.0])
def test_rig_slip_coefficient_gives_the_rigs_linear_leak_as_laminar_slip(theta: float) -> None:
    # paper 002's pump leaks Δp/Rlp (eq. 5); written as paper 000's laminar slip
    # Cs·Δp·D/μ (eq. 4) the same leak needs Cs = μ·k/(D·Rlp): the slip law of
    # sim.components.gear_pump with that Cs must give k times the rig's leak at any Δp,
    # and Cs must grow as the oil cools (μ rises) for the same leak
    rig = reference_rig()
    mu = rig.fluid.dynamic_viscosity(theta)
    for k in (1.0, 2.5):
        cs = rig_slip_coefficient(rig, theta, k)
        for dp in (20e5, 70e5):
            qs, _, _ = flow_losses(dp, 100.0, mu, D=rig.base["pump.Vp"], Cs=cs, Cst=0.0,
                                   rho=870.0, beta_ef=1.5e9)
            assert float(qs) == pytest.approx(k * dp / rig.base["pump.Rlp"], rel=1e-12)
    assert rig_slip_coefficient(rig, 20.0) > rig_slip_coefficient(rig, 50.0)
