"""External gear pump loss model of paper 000 (flow eq. 6, torque eq. 16), vectorised.

Units inside (SI, the paper's nomenclature): pressure difference ``dp`` = p_out − p_in [Pa],
shaft speed ``omega`` [rad/s], derived capacity ``D`` [m³/rad], flow [m³/s], torque [N·m],
dynamic viscosity ``mu`` [Pa·s], density ``rho`` [kg/m³], oil temperature ``theta`` [°C].
With ``D`` per radian and ``omega`` in rad/s the four loss coefficients Cs, Cst, Cv, Cf
are dimensionless, as in the paper's nomenclature.

Delivered flow (paper 000 eq. 6, turbulent term written with eq. 9's exponent)::

    Q = D·ω − Cs·Δp·D/μ − Cst·√(2Δp/ρ)·D^(2/3) − Δp·D·ω/β_ef

* Eq. 5 and 6 of the copy print ``√(2ΔP·D⁴/ρ)``; eq. 9 prints ``D^(4/3)``.  Eq. 5 itself
  says why the second is right: the orifice term goes with d⁴ and d³ ∝ D, so d⁴ ∝ D^(4/3);
  only then is Cst dimensionless (√(Pa·m⁴/(kg/m³)) = m³/s).  Paper 001 Table 1 has the same
  term (Schlösser 1961: ``Vi^(2/3)·√(2Δp/ρ)``).  We use D^(4/3) under the root everywhere.

Shaft torque (paper 000 eq. 16, pump sign convention)::

    T = Δp·D + Cv·μ·ω·D + Cf·Δp·D

* The copy prints eq. 16 with minus signs, the motor convention (torque delivered).  For a
  pump the losses add to the ideal torque Δp·D (eq. 10: T = Ti + Tv + Tf), and eq. 17
  (Cv = (T₁ − T₂)/((μ₁ − μ₂)ωD), positive when the colder, more viscous oil needs more torque)
  only gives a positive Cv with the plus sign.  The seal torque Te is neglected, as in the
  paper.

Both models hold the coefficients as polynomial surfaces C(Δp, ω) (:class:`CoefficientSurface`),
as the paper's conclusion recommends.  The oil density in the turbulent term is constant
(paper 000 §4: "the fluid density was considered to be constant"); viscosity follows the
oil temperature through :class:`sim.fluid.Fluid`.

References
----------
Paper 000: Parameterization, modeling and validation in real conditions of an external gear
pump (Energies), eqs. 1-19.  Paper 001: Panwar and Michael (2018), Table 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import numpy.typing as npt
from numpy.polynomial import polynomial as npoly

from sim.errors import ParameterError
from sim.fluid import Fluid
from sim.params import Param

__all__ = [
    "OMEGA_REF",
    "PARAMETERS",
    "P_REF",
    "CoefficientSurface",
    "GearPump",
    "PumpModel",
    "dynamic_viscosity",
    "flow_losses",
    "gear_pump_flow",
    "gear_pump_torque",
    "mechanical_efficiency",
    "volumetric_efficiency",
]

FloatArray = npt.NDArray[np.float64]
ArrayLike = npt.ArrayLike

#: Pressure scale of the coefficient surfaces [Pa] (100 bar).
P_REF = 1.0e7
#: Speed scale of the coefficient surfaces [rad/s] (1000 rpm).
OMEGA_REF = 2.0 * math.pi * 1000.0 / 60.0

PARAMETERS: tuple[Param, ...] = (
    Param("D", "m^3/rad", 14.7e-6 / (2.0 * math.pi),
          "paper 000 §3.1: derived capacity 14.7 cm³/rev (ISO 8426), equal to the maker's value",
          "derived capacity per radian"),
    Param("rho", "kg/m^3", 865.0,
          "sim.fluid default oil (an HM-grade VG 46, 879 kg/m³ at 15 °C) at 40 °C; constant "
          "as in paper 000 §4", "oil density in the turbulent slip term"),
    Param("beta_ef", "Pa", 1.5e9,
          "chosen: same effective bulk modulus as sim.fluid (paper 002 §2.6); paper 000 gives "
          "no value", "effective bulk modulus of the compressed oil (eq. 6)"),
)


def _f64(x: ArrayLike) -> FloatArray:
    return np.asarray(x, dtype=np.float64)


@dataclass(frozen=True, eq=False)
class CoefficientSurface:
    """A loss coefficient as a polynomial surface in pressure and speed.

    ``C(Δp, ω) = Σᵢⱼ c[i, j] · xⁱ · yʲ`` with ``x = Δp / p_ref`` and ``y = ω / omega_ref``
    (paper 000 §6: "three-dimensional polynomial correlations ... as a function of pressure
    and rotation speed").

    Parameters
    ----------
    coef
        Coefficient matrix ``c[i, j]`` [-], shape (deg_p + 1, deg_n + 1).
    p_ref
        Pressure scale [Pa]; default :data:`P_REF` (100 bar).
    omega_ref
        Speed scale [rad/s]; default :data:`OMEGA_REF` (1000 rpm).
    """

    coef: FloatArray
    p_ref: float = P_REF
    omega_ref: float = OMEGA_REF

    def __post_init__(self) -> None:
        c = np.atleast_2d(np.asarray(self.coef, dtype=np.float64))
        if c.ndim != 2 or not np.all(np.isfinite(c)):
            raise ParameterError("coefficient matrix must be 2-D and finite", field="coef")
        if not (self.p_ref > 0 and self.omega_ref > 0):
            raise ParameterError("scales must be positive", field="p_ref")
        object.__setattr__(self, "coef", c)

    @classmethod
    def constant(cls, value: float) -> CoefficientSurface:
        """A surface that does not depend on pressure or speed."""
        return cls(np.array([[float(value)]]))

    @property
    def degrees(self) -> tuple[int, int]:
        """Polynomial degrees (in pressure, in speed)."""
        return self.coef.shape[0] - 1, self.coef.shape[1] - 1

    def __call__(self, dp: ArrayLike, omega: ArrayLike) -> FloatArray:
        """Value of the coefficient [-] at ``dp`` [Pa] and ``omega`` [rad/s] (broadcast)."""
        x, y = np.broadcast_arrays(_f64(dp) / self.p_ref, _f64(omega) / self.omega_ref)
        return np.asarray(npoly.polyval2d(x, y, self.coef), dtype=np.float64)


def dynamic_viscosity(fluid: Fluid, theta: ArrayLike) -> FloatArray:
    """Dynamic viscosity μ(θ) [Pa·s] of ``fluid`` at temperatures ``theta`` [°C], vectorised.

    :meth:`sim.fluid.Fluid.dynamic_viscosity` (ASTM D341 Walther law) is scalar; it is
    evaluated once per distinct temperature.
    """
    t = _f64(theta)
    flat = t.ravel().tolist()
    if not all(math.isfinite(v) for v in flat):
        raise ParameterError("oil temperature must be finite", field="theta")
    memo: dict[float, float] = {}  # a few distinct temperatures among many: a dict, no sort
    for v in flat:
        if v not in memo:
            memo[v] = fluid.dynamic_viscosity(v)
    return np.array([memo[v] for v in flat], dtype=np.float64).reshape(t.shape)


def flow_losses(
    dp: ArrayLike, omega: ArrayLike, mu: ArrayLike, *,
    D: float, Cs: ArrayLike, Cst: ArrayLike, rho: float, beta_ef: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The three flow losses of paper 000 eq. 6 [m³/s].

    Parameters
    ----------
    dp
        Pressure rise p_out − p_in [Pa], ≥ 0.
    omega
        Shaft speed [rad/s].
    mu
        Dynamic viscosity [Pa·s].
    D
        Derived capacity [m³/rad].
    Cs, Cst
        Laminar and turbulent slip coefficients [-] at each point.
    rho
        Density [kg/m³].
    beta_ef
        Effective bulk modulus [Pa].

    Returns
    -------
    tuple of ndarray
        ``(Qs, Qst, Qc)``: laminar slip ``Cs·Δp·D/μ`` (eq. 4), turbulent slip
        ``Cst·√(2Δp·D^(4/3)/ρ)`` (eq. 5 with eq. 9's exponent) and compressibility
        ``Δp·D·ω/β_ef`` [m³/s].
    """
    dp_a = _f64(dp)
    if np.any(dp_a < 0):
        raise ParameterError("the model holds for pumping, Δp ≥ 0", field="dp")
    qs = _f64(Cs) * dp_a * D / _f64(mu)
    qst = _f64(Cst) * np.sqrt(2.0 * dp_a / rho) * D ** (2.0 / 3.0)
    qc = dp_a * D * _f64(omega) / beta_ef
    return qs, qst, qc


def gear_pump_flow(
    dp: ArrayLike, omega: ArrayLike, mu: ArrayLike, *,
    D: float, Cs: ArrayLike, Cst: ArrayLike, rho: float, beta_ef: float,
) -> FloatArray:
    """Delivered flow Q [m³/s] (paper 000 eq. 6).

    ``Q = D·ω − Cs·Δp·D/μ − Cst·√(2Δp/ρ)·D^(2/3) − Δp·D·ω/β_ef``; arguments as in
    :func:`flow_losses`.  At Δp = 0 it is the geometric flow D·ω.
    """
    qs, qst, qc = flow_losses(dp, omega, mu, D=D, Cs=Cs, Cst=Cst, rho=rho, beta_ef=beta_ef)
    return D * _f64(omega) - qs - qst - qc


def gear_pump_torque(
    dp: ArrayLike, omega: ArrayLike, mu: ArrayLike, *, D: float, Cv: ArrayLike, Cf: ArrayLike,
) -> FloatArray:
    """Shaft torque T [N·m] (paper 000 eq. 16, pump sign convention, see module notes).

    ``T = Δp·D + Cv·μ·ω·D + Cf·Δp·D``: ideal torque (eq. 13), viscous friction (eq. 14) and
    Coulomb / load-dependent friction (eq. 15).  ``dp`` [Pa], ``omega`` [rad/s],
    ``mu`` [Pa·s], ``D`` [m³/rad], ``Cv`` and ``Cf`` [-].
    """
    dp_a = _f64(dp)
    return dp_a * D + _f64(Cv) * _f64(mu) * _f64(omega) * D + _f64(Cf) * dp_a * D


def volumetric_efficiency(q: ArrayLike, omega: ArrayLike, D: float) -> FloatArray:
    """Volumetric efficiency ηv = Q / (D·ω) [-] for flow ``q`` [m³/s] at ``omega`` [rad/s]."""
    return _f64(q) / (D * _f64(omega))


def mechanical_efficiency(torque: ArrayLike, dp: ArrayLike, D: float) -> FloatArray:
    """Hydro-mechanical efficiency ηhm = Δp·D / T [-] (torque [N·m], ``dp`` [Pa])."""
    return _f64(dp) * D / _f64(torque)


class PumpModel(Protocol):
    """What a virtual test bench needs from a pump model (steady state)."""

    def flow(self, dp: ArrayLike, omega: ArrayLike, theta: ArrayLike) -> FloatArray:
        """Delivered flow [m³/s] at ``dp`` [Pa], ``omega`` [rad/s], oil ``theta`` [°C]."""
        ...

    def torque(self, dp: ArrayLike, omega: ArrayLike, theta: ArrayLike) -> FloatArray:
        """Shaft torque [N·m] at ``dp`` [Pa], ``omega`` [rad/s], oil ``theta`` [°C]."""
        ...


@dataclass(frozen=True, eq=False)
class GearPump:
    """A gear pump: eq. 6 and eq. 16 with coefficient surfaces and an oil.

    Parameters
    ----------
    D
        Derived capacity [m³/rad] (default: 14.7 cm³/rev, paper 000 §3.1).
    Cs, Cst, Cv, Cf
        Laminar slip, turbulent slip, viscous and Coulomb friction coefficients [-] as
        surfaces of Δp [Pa] and ω [rad/s].
    rho
        Density in the turbulent term [kg/m³] (default 865, see :data:`PARAMETERS`).
    beta_ef
        Effective bulk modulus [Pa] (default 1.5e9).
    fluid
        The oil; gives μ(θ) (default: ISO VG 46, the oil of paper 000).
    p_range, omega_range
        Pressure rise [Pa] and speed [rad/s] over which the surfaces were fitted; outside
        them the polynomials extrapolate.  The model does not refuse such points (a duty
        cycle may pass through them briefly); :meth:`in_range` tells the caller.
    note
        Where the numbers come from (free text, kept with the model).
    """

    Cs: CoefficientSurface
    Cst: CoefficientSurface
    Cv: CoefficientSurface
    Cf: CoefficientSurface
    D: float = 14.7e-6 / (2.0 * math.pi)
    rho: float = 865.0
    beta_ef: float = 1.5e9
    fluid: Fluid = field(default_factory=Fluid)
    p_range: tuple[float, float] = (0.0, math.inf)
    omega_range: tuple[float, float] = (0.0, math.inf)
    note: str = ""

    def __post_init__(self) -> None:
        for name in ("D", "rho", "beta_ef"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ParameterError(f"{name} must be positive and finite", field=name)

    def in_range(self, dp: ArrayLike, omega: ArrayLike) -> npt.NDArray[np.bool_]:
        """Whether each point lies inside the fitted domain (``p_range`` × ``omega_range``)."""
        d, w = np.broadcast_arrays(_f64(dp), _f64(omega))
        return ((d >= self.p_range[0]) & (d <= self.p_range[1])
                & (w >= self.omega_range[0]) & (w <= self.omega_range[1]))

    def mu(self, theta: ArrayLike) -> FloatArray:
        """Dynamic viscosity [Pa·s] at oil temperature ``theta`` [°C]."""
        return dynamic_viscosity(self.fluid, theta)

    def losses(
        self, dp: ArrayLike, omega: ArrayLike, theta: ArrayLike,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(Qs, Qst, Qc)`` [m³/s] of eq. 6 at ``dp`` [Pa], ``omega`` [rad/s], ``theta`` [°C]."""
        return flow_losses(dp, omega, self.mu(theta), D=self.D, Cs=self.Cs(dp, omega),
                           Cst=self.Cst(dp, omega), rho=self.rho, beta_ef=self.beta_ef)

    def flow(self, dp: ArrayLike, omega: ArrayLike, theta: ArrayLike) -> FloatArray:
        """Delivered flow [m³/s] (eq. 6) at ``dp`` [Pa], ``omega`` [rad/s], ``theta`` [°C]."""
        return gear_pump_flow(dp, omega, self.mu(theta), D=self.D, Cs=self.Cs(dp, omega),
                              Cst=self.Cst(dp, omega), rho=self.rho, beta_ef=self.beta_ef)

    def torque(self, dp: ArrayLike, omega: ArrayLike, theta: ArrayLike) -> FloatArray:
        """Shaft torque [N·m] (eq. 16) at ``dp`` [Pa], ``omega`` [rad/s], ``theta`` [°C]."""
        return gear_pump_torque(dp, omega, self.mu(theta), D=self.D, Cv=self.Cv(dp, omega),
                                Cf=self.Cf(dp, omega))
