"""Compiled laws of the gear-pump bond graph (paper 000 eqs. 4-6 and 13-16, Figure 7).

Every law is a numba scalar function (:func:`sim.bondgraph.laws.law`) that the fragment of
:mod:`sim.components.gear_pump_fragment` attaches to an element.  The equations are those of
the vectorised reference :mod:`sim.components.gear_pump` (the same sign conventions and the
same ``D^(4/3)`` reading of the turbulent term); the tests check that the compiled graph and
the reference agree.

Loss coefficients are surfaces ``C(Δp, ω) = Σᵢⱼ c[i, j]·xⁱ·yʲ`` with ``x = Δp/p_ref`` and
``y = ω/omega_ref`` (paper 000 §6, :class:`~sim.components.gear_pump.CoefficientSurface`),
evaluated here from 16 graph parameters ``c00 … c33`` (degree ≤ 3 in each variable; a
lower-degree surface has zeros).  They arrive as the trailing ``*c`` arguments, in the
order ``c00, c01, c02, c03, c10, …, c33``.

The oil viscosity μ [Pa·s] is a tabulated signal of time (``tbl:NAME.mu``, read with
:func:`~sim.bondgraph.laws.table_lookup`), so a measured temperature record drives the
laminar slip (eq. 4) and the viscous torque (eq. 14) as paper 000 §4 describes.

Units: pressures [Pa], speeds [rad/s], D [m³/rad], flows [m³/s], torques [N·m], μ [Pa·s],
ρ [kg/m³], β_ef [Pa], time [s].
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from sim.bondgraph.laws import law, table_lookup

__all__ = [
    "compression_loss",
    "direction",
    "laminar_slip",
    "load_torque",
    "play_rate",
    "surface_value",
    "turbulent_slip",
    "viscous_torque",
]

Arr = npt.NDArray[np.float64]


@njit(cache=True)
def _poly(x: float, y: float, c: tuple[float, ...]) -> float:
    """Σᵢⱼ c[4i + j]·xⁱ·yʲ for i, j = 0..3 (Horner in both variables)."""
    acc = 0.0
    for i in range(3, -1, -1):
        row = 0.0
        for j in range(3, -1, -1):
            row = row * y + c[4 * i + j]
        acc = acc * x + row
    return acc


@njit(cache=True)
def _laminar(dp: float, omega: float, mu: float, D: float, p_ref: float, omega_ref: float,
             c: tuple[float, ...]) -> float:
    """Cs(Δp, ω)·Δp·D/μ (paper 000 eq. 4)."""
    return _poly(dp / p_ref, omega / omega_ref, c) * dp * D / mu


@njit(cache=True)
def _turbulent(dp: float, omega: float, rho: float, D: float, dp_s: float, p_ref: float,
               omega_ref: float, c: tuple[float, ...]) -> float:
    """Cst(Δp, ω)·√(2Δp·D^(4/3)/ρ) with a smooth, odd root (paper 000 eqs. 5 and 9).

    ``√|Δp|·sgn(Δp)`` is written ``Δp/(Δp² + Δp_s²)^(1/4)``: it is odd, has a finite slope
    at Δp = 0 (the implicit solver needs a Jacobian) and differs from the root by the
    factor ``(1 + (Δp_s/Δp)²)^(−1/4)``, i.e. by 6e-10 relative at 20 bar with Δp_s = 100 Pa.
    """
    root = dp / (dp * dp + dp_s * dp_s) ** 0.25
    return (_poly(dp / p_ref, omega / omega_ref, c) * root * math.sqrt(2.0 / rho)
            * D ** (2.0 / 3.0))


@law
def surface_value(dp: float, omega: float, p_ref: float, omega_ref: float,
                  *c: float) -> float:
    """A loss coefficient C(Δp, ω) [-] at ``dp`` [Pa], ``omega`` [rad/s] (paper 000 §6)."""
    return _poly(dp / p_ref, omega / omega_ref, c)


@law
def laminar_slip(dp: float, omega: float, t: float, p: Arr, off: int, n: int, D: float,
                 p_ref: float, omega_ref: float, *c: float) -> float:
    """Laminar slip Qs = Cs(Δp, ω)·Δp·D/μ(t) [m³/s] (paper 000 eq. 4; MSf LAMIN of Fig. 7).

    ``p, off, n`` are the viscosity table (``tbl:NAME.mu``), read at time ``t``.
    """
    return _laminar(dp, omega, table_lookup(t, p, off, n), D, p_ref, omega_ref, c)


@law
def turbulent_slip(dp: float, omega: float, rho: float, D: float, dp_s: float, p_ref: float,
                   omega_ref: float, *c: float) -> float:
    """Turbulent slip Qst = Cst(Δp, ω)·√(2Δp·D^(4/3)/ρ) [m³/s] (paper 000 eqs. 5, 9; MSf TURB).

    Viscosity-free, as paper 000 §2.1 states; regularised at Δp → 0 over ``dp_s`` [Pa].
    """
    return _turbulent(dp, omega, rho, D, dp_s, p_ref, omega_ref, c)


@law
def compression_loss(dp: float, omega: float, D: float, beta_ef: float) -> float:
    """Flow lost to compressing the swept oil, Qc = Δp·D·ω/β_ef [m³/s] (paper 000 eq. 6; MSf COMP)."""
    return dp * D * omega / beta_ef


@law
def viscous_torque(omega: float, dp: float, t: float, p: Arr, off: int, n: int, D: float,
                   p_ref: float, omega_ref: float, *c: float) -> float:
    """Viscous friction torque Tv = Cv(Δp, ω)·μ(t)·ω·D [N·m] (paper 000 eq. 14; MSe VISC)."""
    return _poly(dp / p_ref, omega / omega_ref, c) * table_lookup(t, p, off, n) * omega * D


@law
def load_torque(omega: float, dp: float, D: float, omega_s: float, p_ref: float,
                omega_ref: float, *c: float) -> float:
    """Load-dependent (Coulomb) torque Tf = Cf(Δp, ω)·|Δp|·D·sgn(ω) [N·m] (eq. 15; MSe COUL).

    ``sgn(ω)`` is ``tanh(ω/ω_s)``, which is exactly 1.0 in floating point for ω > 20·ω_s,
    so at any running speed the torque is eq. 15's ``Cf·Δp·D`` for the pumping Δp ≥ 0.
    """
    return (_poly(dp / p_ref, omega / omega_ref, c) * abs(dp) * D
            * math.tanh(omega / omega_s))


# -- the play operator of the slip hysteresis (paper 000 §5; sim.components.effects) --------

@njit(cache=True)
def _direction(dp: float, m: float, w: float) -> float:
    """Memory of the last pressure change: clip((Δp − m)/w, −1, 1) (+1 rising, −1 falling)."""
    return min(1.0, max(-1.0, (dp - m) / w))


@law
def direction(dp: float, m: float, w: float) -> float:
    """Direction of the last pressure change [-] from the play-operator state ``m`` [Pa]."""
    return _direction(dp, m, w)


@law
def play_rate(e: float, w: float, tau: float) -> float:
    """Rate of the play (backlash) operator, dm/dt = dz(Δp − m, w)/τ [Pa/s].

    ``e = Δp − m``; ``dz`` is the dead zone of half-width ``w`` [Pa]: the memory ``m`` does
    not move while the pressure stays within ``±w`` of it, and follows it (time constant
    ``tau`` [s]) once it leaves the band, so ``Δp − m`` ends at ``+w`` after a rise and
    ``−w`` after a fall.
    """
    if e > w:
        return (e - w) / tau
    if e < -w:
        return (e + w) / tau
    return 0.0
