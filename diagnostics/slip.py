"""Laminar slip coefficient Cs of a pump from field measurements (paper 000 eqs. 6-7).

Paper 000 eq. 6 gives the delivered flow of a gear pump as the geometric flow less three
losses (laminar slip, turbulent slip, compressibility)::

    Q = D·ω − Cs·Δp·D/μ − Cst·√(2Δp·D^(4/3)/ρ) − Δp·D·ω/β_ef          (eq. 6)

Two field inversions:

* :func:`slip_coefficient` — one steady point (flow, pressure, speed, temperature) and the
  pump's bench-fitted ``Cst`` surface, ``D``, ``ρ`` and ``β_ef``.  Eq. 6 is linear in Cs, so
  ``Cs = (Q(Cs=0) − Q_meas)/(Q(Cs=0) − Q(Cs=1))``; the forward model is
  :func:`sim.components.gear_pump.gear_pump_flow` itself (eq. 6 is written once, there).
* :func:`slip_coefficient_two_temperatures` — two points at the same pressure and speed
  but different oil temperatures (a cold start and a warm run).  Only the laminar term
  depends on viscosity, so the difference isolates it (eq. 7)::

      Cs = (q₁ − q₂) / (Δp·D·(1/μ₂ − 1/μ₁))                          (eq. 7)

  and needs neither Cst nor β_ef.  A small speed difference between the two points is
  corrected by removing ``D·(ω₁ − ω₂)`` from the flow difference.

The pressure rise Δp is the record's ``pump_pressure`` (gauge outlet pressure; the inlet is
taken at 0 bar gauge).  The flow is ``pump_flow``, else meter B (paper 002's rig: equal
while the relief valve is shut — a note says so).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from diagnostics.measurement import MeasurementRecord
from diagnostics.quantity import Quantity, agree
from diagnostics.uncertainty import Estimate, Method, propagate
from sim.components.gear_pump import GearPump, dynamic_viscosity, gear_pump_flow
from sim.errors import MeasurementError
from sim.fluid import Fluid
from sim.rigs import Rig

__all__ = ["rig_slip_coefficient", "slip_coefficient", "slip_coefficient_two_temperatures"]

FloatArray = NDArray[np.float64]


def _pump_inputs(record: MeasurementRecord, tag: str = "") -> tuple[dict[str, Quantity],
                                                                     list[str]]:
    """Flow, pressure, speed and temperature of a pump point, keyed ``name + tag``."""
    notes: list[str] = []
    flow = record.pump_flow
    if flow is None:
        flow = record.flow_B
        if flow is None:
            raise MeasurementError("the pump flow (or meter B) is needed", field="pump_flow")
        notes.append("meter B taken as the pump flow: valid while the relief valve is shut")
    if record.pump_pressure is None:
        raise MeasurementError("the pump pressure is needed", field="pump_pressure")
    if record.pump_pressure.value <= 0.0:
        raise MeasurementError("the slip coefficient needs a pressure rise > 0",
                               field="pump_pressure")
    if record.condition.pump_speed is None:
        raise MeasurementError("the pump speed is needed", field="condition.pump_speed")
    inputs = {f"flow{tag}": flow, f"dp{tag}": record.pump_pressure,
              f"omega{tag}": record.condition.pump_speed,
              f"theta{tag}": record.condition.oil_temperature}
    return inputs, notes


def slip_coefficient(record: MeasurementRecord, pump: GearPump, *, method: Method = "auto",
                     n: int = 20_000, rng: np.random.Generator | None = None) -> Estimate:
    """Laminar slip coefficient Cs [-] at one field point (paper 000 eq. 6 solved for Cs).

    Parameters
    ----------
    record
        Needs the pump flow (or meter B), pump pressure [Pa], pump speed [rad/s] and oil
        temperature [°C].
    pump
        The pump's model: ``D`` [m³/rad], ``rho`` [kg/m³], ``beta_ef`` [Pa], the oil, and
        the ``Cst`` surface from the bench.  Its ``Cs`` surface is the healthy reference:
        ``derived["Cs_reference"]`` is its value at this point.
    method, n, rng
        Propagation (:func:`diagnostics.uncertainty.propagate`).

    Returns
    -------
    Estimate
        ``derived`` holds the laminar slip flow ``Q_s`` [m³/s], the volumetric efficiency
        ``eta_v`` [-], ``mu`` [Pa·s] and ``Cs_reference`` [-].
    """
    inputs, notes = _pump_inputs(record)

    def model(x: Mapping[str, FloatArray]) -> FloatArray:
        dp = np.where(x["dp"] > 0.0, x["dp"], np.nan)
        omega, mu = x["omega"], dynamic_viscosity(pump.fluid, x["theta"])
        cst = pump.Cst(dp, omega)
        q0 = gear_pump_flow(dp, omega, mu, D=pump.D, Cs=0.0, Cst=cst, rho=pump.rho,
                            beta_ef=pump.beta_ef)
        q1 = gear_pump_flow(dp, omega, mu, D=pump.D, Cs=1.0, Cst=cst, rho=pump.rho,
                            beta_ef=pump.beta_ef)
        return np.asarray((q0 - x["flow"]) / (q0 - q1), dtype=np.float64)

    est = propagate(model, inputs, quantity="Cs", unit="1", method=method, n=n, rng=rng)
    dp, omega = inputs["dp"].value, inputs["omega"].value
    mu = pump.fluid.dynamic_viscosity(inputs["theta"].value)
    derived = {"Q_s": est.value * dp * pump.D / mu,
               "eta_v": inputs["flow"].value / (pump.D * omega), "mu": mu,
               "Cs_reference": float(pump.Cs(dp, omega))}
    return replace(est, derived=derived, notes=est.notes + tuple(notes))


def slip_coefficient_two_temperatures(cold: MeasurementRecord, warm: MeasurementRecord,
                                      D: float, *, fluid: Fluid | None = None,
                                      method: Method = "auto", n: int = 20_000,
                                      rng: np.random.Generator | None = None) -> Estimate:
    """Laminar slip coefficient Cs [-] from two oil temperatures (paper 000 eq. 7).

    Parameters
    ----------
    cold, warm
        Records at the same pump pressure and speed (within ``CONSISTENCY_K`` standard
        uncertainties) and clearly different oil temperatures.
    D
        Derived capacity [m³/rad].
    fluid
        The oil (viscosity from temperature); default ISO VG 46.
    method, n, rng
        Propagation (:func:`diagnostics.uncertainty.propagate`).

    Raises
    ------
    MeasurementError
        Missing fields, pressures or speeds that differ, or temperatures that do not.
    """
    fl = Fluid() if fluid is None else fluid
    a, notes_a = _pump_inputs(cold, "1")
    b, notes_b = _pump_inputs(warm, "2")
    for name in ("dp", "omega"):
        if not agree(a[f"{name}1"], b[f"{name}2"]):
            raise MeasurementError(
                "eq. 7 needs both points at the same pressure and speed",
                field="pump_pressure" if name == "dp" else "condition.pump_speed")
    t1, t2 = a["theta1"], b["theta2"]
    if abs(t1.value - t2.value) <= 3.0 * math.hypot(t1.u, t2.u):
        raise MeasurementError("the two oil temperatures must differ clearly",
                               field="condition.oil_temperature")
    inputs = {**a, **b}

    def model(x: Mapping[str, FloatArray]) -> FloatArray:
        mu1 = dynamic_viscosity(fl, x["theta1"])
        mu2 = dynamic_viscosity(fl, x["theta2"])
        dp = 0.5 * (x["dp1"] + x["dp2"])
        dq = x["flow1"] - x["flow2"] - D * (x["omega1"] - x["omega2"])
        return np.asarray(dq / (dp * D * (1.0 / mu2 - 1.0 / mu1)), dtype=np.float64)

    est = propagate(model, inputs, quantity="Cs", unit="1", method=method, n=n, rng=rng)
    derived = {"mu1": fl.dynamic_viscosity(t1.value), "mu2": fl.dynamic_viscosity(t2.value)}
    notes = tuple(dict.fromkeys(notes_a + notes_b))
    return replace(est, derived=derived, notes=est.notes + notes)


def rig_slip_coefficient(rig: Rig, temperature: float, leak_factor: float = 1.0) -> float:
    """Laminar slip coefficient Cs [-] of ``rig``'s pump at oil ``temperature`` [°C] when it
    leaks ``leak_factor`` [-] times its document's leakage (the diagnosis's ``pump_leak``).

    Paper 000 eq. 6 writes the slip as ``Cs·D·Δp/μ``; the rig's pump leaks
    ``k·Δp/R_lp`` (its leakage resistance ``pump.Rlp`` [Pa·s/m³]) with ``D = pump.Vp``
    [m³/rad], so ``Cs = μ(T)·k/(D·R_lp)``."""
    mu = rig.fluid.dynamic_viscosity(temperature)
    return float(mu * leak_factor / (rig.base["pump.Vp"] * rig.base["pump.Rlp"]))
