"""Hydraulic fluid properties: viscosity from temperature, density, effective bulk modulus.

Viscosity follows the Walther equation of ASTM D341,

.. math:: \\log_{10}\\log_{10}(\\nu + 0.7) = A - B \\log_{10} T

with :math:`\\nu` in cSt and :math:`T` in K, fitted through two reference points
(a data-sheet pair such as 40 °C and 100 °C).  Density falls linearly with temperature
with the thermal expansion coefficient :math:`\\alpha`,
:math:`\\rho(T) = \\rho_{15}\\,[1 - \\alpha (T - 15\\,°C)]`.  The effective bulk modulus
is a constant of the rig (paper 002 §2.6: β = 1.5e9 Pa).

Defaults describe an ISO VG 46 mineral oil of the HM grade (viscosity index ≈ 98): 46 cSt
at 40 °C, 6.8 cSt at 100 °C, 879 kg/m³ at 15 °C, the Tellus S2 M 46 data sheet's typical
values (paper 002 names no oil; the seeds README suggests a VG 46).  Paper 000's oil, Tellus
S2 V 46, is an HV grade (VI ≈ 150, about 8 cSt at 100 °C): at 22 °C and 60 °C, the two
temperatures of its two-temperature method, these defaults read 14 % more and 9 % less
viscous than an 8.2 cSt oil would, so bench data of such an oil need its own data-sheet pair
(``Fluid(nu2=...)``).

References
----------
ASTM D341, Standard practice for viscosity-temperature equations for liquid petroleum products.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim.errors import ParameterError
from sim.params import Param

__all__ = ["FLUID_PARAMETERS", "Fluid"]

_ABS_ZERO = 273.15
#: below this kinematic viscosity [m²/s] (0.3 cSt) the Walther law has no value
WALTHER_MIN = 0.3e-6

FLUID_PARAMETERS: tuple[Param, ...] = (
    Param("nu1", "m^2/s", 46e-6, "ISO 3448 VG 46: 46 cSt at 40 °C",
          "kinematic viscosity at reference temperature T1"),
    Param("T1", "degC", 40.0, "ISO 3448 reference temperature", "first reference temperature",
          lower=-60.0, upper=200.0),
    Param("nu2", "m^2/s", 6.8e-6, "chosen: an HM-grade VG 46, 6.8 cSt at 100 °C (Tellus S2 M 46 "
          "data sheet; paper 000's S2 V 46 is an HV grade, ≈ 8 cSt)",
          "kinematic viscosity at reference temperature T2"),
    Param("T2", "degC", 100.0, "ISO 3448 reference temperature", "second reference temperature",
          lower=-60.0, upper=250.0),
    Param("rho15", "kg/m^3", 879.0, "chosen: HM-grade VG 46 (Tellus S2 M 46 data sheet)",
          "density at 15 °C"),
    Param("alpha", "1/K", 6.5e-4, "typical mineral oil thermal expansion", "volumetric expansion"),
    Param("beta", "Pa", 1.5e9, "paper 002 §2.6 (repaired '.5 e9')", "effective bulk modulus"),
)


@dataclass(frozen=True, slots=True)
class Fluid:
    """A hydraulic oil.

    Parameters
    ----------
    nu1, nu2
        Kinematic viscosities at ``T1`` and ``T2`` [m²/s].
    T1, T2
        Reference temperatures [°C].
    rho15
        Density at 15 °C [kg/m³].
    alpha
        Volumetric thermal expansion coefficient [1/K].
    beta
        Effective bulk modulus [Pa].
    """

    nu1: float = 46e-6
    T1: float = 40.0
    nu2: float = 6.8e-6
    T2: float = 100.0
    rho15: float = 879.0
    alpha: float = 6.5e-4
    beta: float = 1.5e9

    def __post_init__(self) -> None:
        if not (self.nu1 > WALTHER_MIN and self.nu2 > WALTHER_MIN):
            # Walther's log10 log10(ν + 0.7) has no value at or below 0.3 cSt: a viscosity
            # typed in m²/s where cSt was asked crashed the law (a verification pass)
            raise ParameterError(
                f"viscosities must be above {WALTHER_MIN * 1e6:g} cSt (ASTM D341's Walther "
                f"law), got {self.nu1:g} and {self.nu2:g} m²/s",
                field="fluid.nu1" if not self.nu1 > WALTHER_MIN else "fluid.nu2")
        if self.T1 == self.T2:
            raise ParameterError("the two reference temperatures must differ", field="fluid.T2")
        if (self.nu1 - self.nu2) * (self.T1 - self.T2) >= 0:
            raise ParameterError("viscosity must fall as temperature rises", field="fluid.nu2")
        if self.beta <= 0 or self.rho15 <= 0:
            raise ParameterError("bulk modulus and density must be positive", field="fluid.beta")

    def _walther(self) -> tuple[float, float]:
        """Walther constants (A, B) through the two reference points (ASTM D341)."""
        z1 = math.log10(math.log10(self.nu1 * 1e6 + 0.7))
        z2 = math.log10(math.log10(self.nu2 * 1e6 + 0.7))
        l1 = math.log10(self.T1 + _ABS_ZERO)
        l2 = math.log10(self.T2 + _ABS_ZERO)
        b = (z1 - z2) / (l2 - l1)
        return z1 + b * l1, b

    def kinematic_viscosity(self, T: float) -> float:
        """Kinematic viscosity ν(T) [m²/s] at temperature ``T`` [°C] (ASTM D341)."""
        if not (-60.0 <= T <= 250.0):
            raise ParameterError(f"oil temperature {T} °C is outside -60..250 °C", field="T")
        a, b = self._walther()
        z = a - b * math.log10(T + _ABS_ZERO)
        return (10.0 ** (10.0**z) - 0.7) * 1e-6

    def density(self, T: float) -> float:
        """Density ρ(T) [kg/m³] at ``T`` [°C]: ρ15·(1 − α (T − 15))."""
        return self.rho15 * (1.0 - self.alpha * (T - 15.0))

    def dynamic_viscosity(self, T: float) -> float:
        """Dynamic viscosity μ(T) = ρ(T)·ν(T) [Pa·s] at ``T`` [°C]."""
        return self.density(T) * self.kinematic_viscosity(T)
