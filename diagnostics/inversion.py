"""Equivalent internal clearances of cylinder and valve from measured bypass flows.

Paper 002 §2.7 defines the *equivalent clearance* of a component as the clearance that,
alone, would let pass the flow that bypasses it.  The bypass flows are measured in the
working phase:

* **cylinder** — meter C (flow out of chamber 2) minus the displacement flow:
  ``Q_lc = Q_C − A2·ẋ``;  then the leakage law (paper 002 eq. 36, with the Couette sign of
  :mod:`sim.components.cylinder`: relative to the piston the Couette term opposes motion)

  .. math:: Q_{lc} = \\underbrace{\\frac{\\pi D_c (P_1 - P_2)}{12 \\mu L_c}}_{a} c_c^3
                     - \\underbrace{\\frac{\\pi D_c \\dot x}{2}}_{b} c_c

  is solved for ``cc`` (:func:`~diagnostics.leakage_laws.leakage_root`);
* **valve** — meter B (valve inlet) minus meter C, less the area-difference flow of an
  unequal-area cylinder: ``Q_lv = Q_B − Q_C − (A1 − A2)·ẋ`` (paper 002 eqs. 10, 25-26);
  then the spool law (paper 002 eq. 23, :func:`sim.components.directional_valve.spool_leakage_flow`)
  ``Q_lv = π·Dv·cv³·ΔP/(12·μ·Ls)`` gives ``cv = (12·μ·Ls·Q_lv/(π·Dv·ΔP))^(1/3)``, with
  ``ΔP = P_pump − PRpv − PRvt`` (paper 002 eqs. 8, 24).

The coefficients ``a`` and ``b`` are read off the forward laws of :mod:`sim.components`
themselves (evaluated at unit clearance, unit pressure, unit speed and unit viscosity; the
laws are linear in ΔP, ẋ and 1/μ), so the inversion cannot drift from the simulator.
Viscosity comes from :meth:`sim.fluid.Fluid.dynamic_viscosity` at the oil temperature.

Every estimate carries an uncertainty propagated from the record's uncertainties by
:mod:`diagnostics.uncertainty` (delta method or Monte Carlo).  With ``method="auto"`` Monte
Carlo is used when the result is nonlinear (relative u > 5 %) *or* the bypass lies within
``CONSISTENCY_K`` standard uncertainties of the least the law allows: there the point
estimate sits on the clipped bound, whose first-order sensitivity to the flow is zero, and a
delta interval would be falsely narrow.  The geometry is taken as exact.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from diagnostics.consistency import RigLimits
from diagnostics.leakage_laws import (
    leakage_root,
    piston_clearance,
    piston_law_coefficients,
    spool_clearance,
    spool_law_coefficient,
)
from diagnostics.measurement import MeasurementRecord
from diagnostics.quantity import CONSISTENCY_K, Quantity
from diagnostics.uncertainty import Estimate, Method, propagate
from sim.components.gear_pump import dynamic_viscosity
from sim.errors import MeasurementError, ParameterError
from sim.fluid import Fluid

__all__ = [
    "LeakageGeometry",
    "cylinder_clearance",
    "leakage_root",
    "piston_clearance",
    "piston_law_coefficients",
    "spool_clearance",
    "spool_law_coefficient",
    "valve_clearance",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class LeakageGeometry:
    """Geometry of the leakage paths and of the pump, SI units (names as in the rig file).

    Parameters
    ----------
    bore
        Piston (bore) diameter Dc [m].
    Lc
        Piston seal (land) length [m].
    A1, A2
        Effective piston areas of chambers 1 and 2 [m²].
    Dv
        Spool diameter [m].
    Ls
        Effective sealing length of the spool leakage path [m].
    stroke
        Cylinder stroke [m].
    Vp
        Pump geometric displacement [m³/rad].
    speed
        Nominal pump speed ω [rad/s].
    PRpv
        Pressure drop from pump outlet to valve inlet [Pa] (paper 002 eq. 8).
    PRvt
        Pressure of the valve T port above tank [Pa] (paper 002 eq. 24).
    """

    bore: float
    Lc: float
    A1: float
    A2: float
    Dv: float
    Ls: float
    stroke: float
    Vp: float
    speed: float
    PRpv: float = 0.0
    PRvt: float = 0.0

    def __post_init__(self) -> None:
        for name in ("bore", "Lc", "A1", "A2", "Dv", "Ls", "stroke", "Vp", "speed"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ParameterError(f"must be finite and > 0, got {value}", field=name)
        for name in ("PRpv", "PRvt"):
            if not math.isfinite(getattr(self, name)):
                raise ParameterError("must be finite", field=name)

    def limits(self) -> RigLimits:
        """The rig limits that a record is checked against (:mod:`diagnostics.consistency`)."""
        return RigLimits(Vp=self.Vp, speed=self.speed, A1=self.A1, A2=self.A2,
                         stroke=self.stroke)


#: z of the 95 % interval [-]
_Z95 = 1.959963984540054


def _at_bound(est: Estimate, model: Callable[[Mapping[str, FloatArray]], FloatArray],
              inputs: Mapping[str, Quantity], flow: str, u_q: float) -> Estimate:
    """``est`` with the interval of an estimate within :data:`CONSISTENCY_K` standard
    uncertainties of its physical bound, where the delta method was asked for (the
    diagnosis's fast path): the law's clip (no bypass below zero) made its derivative 0
    and gave a worn-free spool the interval [0, 0] — a zero-width "no clearance" stored in
    the trend (an engineer's pass: 2 of 8 noise draws of the reference rig's healthy
    record).  The clearance rises monotonically with the bypass, whose uncertainty
    ``u_q`` [m³/s] dominates there, so the interval is the law at the bypass's own 95 %
    bounds: ``flow`` (the reading the bypass moves one for one with) shifted by ±1.96·u_q,
    the other inputs at their values; 2 evaluations (Monte Carlo took ~6 ms: a viscosity
    per draw)."""
    def at(shift: float) -> float:
        x = {k: np.array([q.value]) for k, q in inputs.items()}
        x[flow] = x[flow] + shift
        value = float(np.asarray(model(x))[0])
        return max(value, 0.0) if math.isfinite(value) else 0.0

    low, high = sorted((at(-_Z95 * u_q), at(_Z95 * u_q)))
    low, high = min(low, est.value), max(high, est.value)
    return replace(est, low=low, high=high, u=(high - low) / (2.0 * _Z95),
                   notes=(*est.notes, "the interval is the law at the bypass's own 95 % "
                          "bounds (at the physical bound the delta method's derivative is 0)"))


def _require(record: MeasurementRecord, name: str) -> Quantity:
    q = getattr(record, name)
    if q is None:
        raise MeasurementError("needed for this inversion but not in the record", field=name)
    return q


def _speed(record: MeasurementRecord, geometry: LeakageGeometry) -> Quantity:
    v = record.speed("work", stroke=Quantity(geometry.stroke))
    if v is None:
        raise MeasurementError("the working-phase speed (or its duration) is needed",
                               field="speed_work")
    return v


def cylinder_clearance(record: MeasurementRecord, geometry: LeakageGeometry, *,
                       fluid: Fluid, method: Method = "auto",
                       n: int = 20_000, rng: np.random.Generator | None = None,
                       reference: float | None = None) -> Estimate:
    """Equivalent piston clearance ``cc`` [m] from a working-phase record (paper 002 §2.7).

    Needs ``flow_C``, ``p1``, ``p2``, the working speed (stated, or stroke/duration) and the
    oil temperature.  ``derived`` holds the bypass flow ``Q_lc`` [m³/s], ``dp`` [Pa], ``mu``
    [Pa·s] and the least-leakage clearance ``c_star`` [m] (see :func:`leakage_root`).
    ``fluid`` is the rig's oil (:meth:`sim.rigs.schema.RigSpec.fluid_model`); it has no
    default, since the clearance scales with μ^(1/3) and another oil's μ is another rig's
    clearance.

    Where the moving piston's Couette drag outweighs the Poiseuille leak (the bypass
    ``Q_C − A2·ẋ ≤ 0``: cold oil, a low pressure difference, a tight seal), two clearances
    give the same bypass, one on each side of ``c*``, and the bypass cannot tell them apart.
    With ``reference`` (the rig document's clearance [m]) the one nearer it is the value, the
    interval spans both roots' 95 % bounds, ``derived`` holds the other as ``other_root``,
    and a note names both; without it the rising-branch root is reported (as before: the
    healthy reference rig at −30 °C read 309 µm [207, 434] for its 83 µm, an edge pass).

    Raises
    ------
    MeasurementError
        A needed field is missing; P1 ≤ P2; or the bypass lies below the law's minimum by
        more than ``CONSISTENCY_K`` standard uncertainties.
    """
    inputs = {"flow_C": _require(record, "flow_C"), "speed_work": _speed(record, geometry),
              "p1": _require(record, "p1"), "p2": _require(record, "p2"),
              "oil_temperature": record.condition.oil_temperature}
    a_unit, b_unit = piston_law_coefficients(geometry.bore, geometry.Lc)
    v, dp = inputs["speed_work"], inputs["p1"].value - inputs["p2"].value
    if dp <= 0.0:
        raise MeasurementError("P1 must exceed P2 in the working phase", field="p1")
    mu = fluid.dynamic_viscosity(inputs["oil_temperature"].value)
    q = inputs["flow_C"].value - geometry.A2 * v.value
    u_q = math.hypot(inputs["flow_C"].u, geometry.A2 * v.u)
    a, b = a_unit * dp / mu, b_unit * v.value
    c_star = math.sqrt(b / (3.0 * a)) if b > 0.0 else 0.0
    q_min = -(2.0 / 3.0) * b * c_star
    if q < q_min - CONSISTENCY_K * u_q:
        raise MeasurementError(
            f"bypass flow Q_C − A2·ẋ = {q:.4g} m³/s is below the least the leakage law allows "
            f"({q_min:.4g} m³/s) by more than {CONSISTENCY_K:g} standard uncertainties",
            field="flow_C")
    notes: list[str] = []
    two_roots = b > 0.0 and q_min <= q <= 0.0
    if q < q_min:
        notes.append("bypass below the law's minimum: the least-residual clearance is reported")
    elif q <= 0.0 and reference is None:
        notes.append("bypass ≤ 0: a second, smaller root exists on the falling branch; the "
                     "rising-branch root is reported")
    if q - q_min < 2.0 * u_q and not (two_roots and reference is not None):
        notes.append("the bypass flow is within 2 standard uncertainties of the smallest the law "
                     "allows: the lower bound is the physical limit, not a measurement")
    near_bound = q - q_min < CONSISTENCY_K * u_q  # first-order sensitivities mislead there

    def on(branch: Literal["rising", "falling"]) -> Estimate:
        def law(x: Mapping[str, FloatArray]) -> FloatArray:
            mu_x = dynamic_viscosity(fluid, x["oil_temperature"])
            q_x = x["flow_C"] - geometry.A2 * x["speed_work"]
            return leakage_root(a_unit * (x["p1"] - x["p2"]) / mu_x,
                                b_unit * x["speed_work"], q_x, branch)
        found = propagate(law, inputs, quantity="cc", unit="m", method=method, lower=0.0, n=n,
                          rng=rng, nonlinear=near_bound)
        return _at_bound(found, law, inputs, "flow_C", u_q) \
            if near_bound and method == "delta" else found

    derived = {"Q_lc": q, "u_Q_lc": u_q, "dp": dp, "mu": mu, "c_star": c_star}
    if not (two_roots and reference is not None):
        est = on("rising")
        return replace(est, derived=derived, notes=est.notes + tuple(notes))
    rising, falling = on("rising"), on("falling")
    if q + _Z95 * u_q >= 0.0:
        # the falling root runs to 0 as the bypass rises to 0: within the bypass's 95 %
        # bound it reads any clearance down to 0 (the interval's low end was the value
        # itself, 60.0 [60.0, 440.2] µm: a verification pass)
        falling = replace(falling, low=0.0)
    chosen, other = ((falling, rising) if abs(falling.value - reference)
                     < abs(rising.value - reference) else (rising, falling))
    notes.append(
        f"two clearances give this bypass ({q:.3g} m³/s, the piston's drag outweighing its "
        f"leak): {falling.value * 1e6:.4g} µm and {rising.value * 1e6:.4g} µm, either side of "
        f"{c_star * 1e6:.4g} µm; the one nearer the rig's {reference * 1e6:.4g} µm is the "
        "value, the interval spans both (a higher pressure difference or warmer oil "
        "separates them)")
    low, high = min(falling.low, rising.low), max(falling.high, rising.high)
    return replace(chosen, low=low, high=high, u=max(chosen.u, (high - low) / (2.0 * _Z95)),
                   derived=derived | {"other_root": other.value},
                   notes=chosen.notes + tuple(notes))


def valve_clearance(record: MeasurementRecord, geometry: LeakageGeometry, *,
                    fluid: Fluid, method: Method = "auto",
                    n: int = 20_000, rng: np.random.Generator | None = None) -> Estimate:
    """Equivalent spool clearance ``cv`` [m] from a working-phase record (paper 002 §2.7).

    Needs ``flow_B``, ``flow_C``, ``pump_pressure``, the oil temperature and, for an
    unequal-area cylinder, the working speed.  ``derived`` holds the bypass ``Q_lv``
    [m³/s], ``dp`` = P_pump − PRpv − PRvt [Pa] and ``mu`` [Pa·s].  A bypass below zero
    within its uncertainty gives ``cv = 0`` (no detectable leak).  ``fluid``: the rig's oil,
    as for :func:`cylinder_clearance`.
    """
    inputs = {"flow_B": _require(record, "flow_B"), "flow_C": _require(record, "flow_C"),
              "pump_pressure": _require(record, "pump_pressure"),
              "oil_temperature": record.condition.oil_temperature}
    area = geometry.A1 - geometry.A2
    if area != 0.0:
        inputs["speed_work"] = _speed(record, geometry)
    k_unit = spool_law_coefficient(geometry.Dv, geometry.Ls)
    drop = geometry.PRpv + geometry.PRvt

    def bypass(x: Mapping[str, FloatArray]) -> FloatArray:
        v = x["speed_work"] if area != 0.0 else 0.0
        return np.asarray(x["flow_B"] - x["flow_C"] - area * v, dtype=np.float64)

    def model(x: Mapping[str, FloatArray]) -> FloatArray:
        mu = dynamic_viscosity(fluid, x["oil_temperature"])
        dp = x["pump_pressure"] - drop
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.cbrt(np.maximum(bypass(x), 0.0) * mu / (k_unit * dp))
        return np.where(dp > 0.0, c, np.nan)

    q = float(bypass({k: np.array([x.value]) for k, x in inputs.items()})[0])
    u_v = inputs["speed_work"].u if area != 0.0 else 0.0
    u_q = math.sqrt(inputs["flow_B"].u ** 2 + inputs["flow_C"].u ** 2 + (area * u_v) ** 2)
    dp = inputs["pump_pressure"].value - drop
    if dp <= 0.0:
        raise MeasurementError(f"pump pressure leaves no pressure across the valve "
                               f"(ΔP = {dp:.4g} Pa)", field="pump_pressure")
    if q < -CONSISTENCY_K * u_q:
        raise MeasurementError(f"valve bypass Q_B − Q_C = {q:.4g} m³/s is negative beyond "
                               f"{CONSISTENCY_K:g} standard uncertainties", field="flow_C")
    notes: list[str] = []
    if q < 2.0 * u_q:
        notes.append("the valve bypass is within 2 standard uncertainties of zero: the lower "
                     "bound is the physical limit, not a measurement")
    near_bound = q < CONSISTENCY_K * u_q  # first-order sensitivities mislead there
    est = propagate(model, inputs, quantity="cv", unit="m", method=method, lower=0.0, n=n,
                    rng=rng, nonlinear=near_bound)
    if near_bound and method == "delta":
        est = _at_bound(est, model, inputs, "flow_B", u_q)
    mu = fluid.dynamic_viscosity(inputs["oil_temperature"].value)
    derived = {"Q_lv": q, "u_Q_lv": u_q, "dp": dp, "mu": mu}
    return replace(est, derived=derived, notes=est.notes + tuple(notes))
