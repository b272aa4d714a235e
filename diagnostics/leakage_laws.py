"""The leakage laws of piston and spool inverted on plain numbers: the clearance that lets a
given leak pass (paper 002 eqs. 23 and 36, read off the forward laws of
:mod:`sim.components` so the inversion cannot drift from the simulator).  The inversions
of measured records, with their uncertainties, are :mod:`diagnostics.inversion`'s.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sim.components.cylinder import piston_leakage_flow
from sim.components.directional_valve import spool_leakage_flow
from sim.errors import InputError

__all__ = ["leakage_root", "piston_clearance", "piston_law_coefficients", "spool_clearance",
           "spool_law_coefficient"]

FloatArray = NDArray[np.float64]


def leakage_root(a: ArrayLike, b: ArrayLike, q: ArrayLike,
                 branch: Literal["rising", "falling"] = "rising") -> FloatArray:
    """Physical root ``c ≥ 0`` of ``a·c³ − b·c = q`` (vectorised), for ``a > 0``.

    Parameters
    ----------
    a
        Poiseuille coefficient [m³/s per m³], must be > 0 (``nan`` is returned otherwise).
    b
        Couette coefficient [m³/s per m], any sign.
    q
        Leakage flow [m³/s].
    branch
        Where two roots exist (``b > 0``, ``f_min ≤ q ≤ 0``, below): ``"rising"`` (default)
        the one at ``c ≥ c*``, ``"falling"`` the one below it,
        ``2c*·cos(⅓·acos z − 2π/3)``; elsewhere the one root either way.

    Returns
    -------
    ndarray
        Clearance [m].

    Notes
    -----
    Let ``f(c) = a·c³ − b·c`` on ``c ≥ 0``.

    * ``b ≤ 0``: ``f' = 3ac² − b > 0`` for ``c > 0`` and ``f(0) = 0``, so ``f`` is a
      bijection of ``[0, ∞)`` onto itself: for ``q ≥ 0`` there is exactly one root,
      ``c = 2√(|b|/3a)·sinh(⅓·asinh(w))``, ``w = (3q/2|b|)·√(3a/|b|)`` (``∛(q/a)`` for
      ``b = 0``).  For ``q < 0`` no clearance explains the flow; 0 is returned.
    * ``b > 0`` (motion against the Poiseuille flow): ``f`` falls from 0 to its minimum
      ``f_min = −(2/3)·b·c*`` at ``c* = √(b/3a)``, then rises monotonically to ∞.  For
      ``q > 0`` the root is **unique**: on ``(0, √(b/a)]`` ``f ≤ 0 < q``, and on
      ``(√(b/a), ∞)`` ``f' > 3b − b > 0`` with ``f`` running from 0 to ∞.  For
      ``f_min ≤ q ≤ 0`` there is a second root below ``c*``, on the branch where a larger
      clearance would leak *less*; the physical root is the one on the rising branch
      (``c ≥ c*``), where leakage grows with clearance as paper 002 §3 observes (3rd-degree
      rising curves) — it is also the largest real root.  With ``z = q/|f_min|``:
      ``c = 2c*·cosh(⅓·acosh z)`` for ``z ≥ 1``, ``2c*·cos(⅓·acos z)`` for ``|z| < 1``.
      For ``q < f_min`` no clearance explains the flow; the least-residual clearance
      ``c*`` is returned.

    One Newton step on the rising branch polishes the closed form to round-off.
    """
    a_, b_, q_ = (np.asarray(x, dtype=np.float64) for x in np.broadcast_arrays(a, b, q))
    c = np.full(a_.shape, np.nan)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ok = a_ > 0.0
        cs = np.sqrt(np.abs(b_) / (3.0 * a_))
        fmin = (2.0 / 3.0) * np.abs(b_) * cs
        z = q_ / fmin
        use_cbrt = ok & ~np.isfinite(z)
        c = np.where(use_cbrt, np.cbrt(np.maximum(q_, 0.0) / a_), c)
        neg = ok & np.isfinite(z) & (b_ < 0.0)
        c = np.where(neg, 2.0 * cs * np.sinh(np.arcsinh(np.maximum(z, 0.0)) / 3.0), c)
        pos = ok & np.isfinite(z) & (b_ > 0.0)
        hi = pos & (z >= 1.0)
        c = np.where(hi, 2.0 * cs * np.cosh(np.arccosh(np.maximum(z, 1.0)) / 3.0), c)
        mid = pos & (z < 1.0) & (z >= -1.0)
        c = np.where(mid, 2.0 * cs * np.cos(np.arccos(np.clip(z, -1.0, 1.0)) / 3.0), c)
        if branch == "falling":
            low = pos & (z <= 0.0) & (z >= -1.0)
            c = np.where(low, 2.0 * cs * np.cos(np.arccos(np.clip(z, -1.0, 1.0)) / 3.0
                                                - 2.0 * np.pi / 3.0), c)
        c = np.where(pos & (z < -1.0), cs, c)
        # Newton polish where the branch is well conditioned (away from c*)
        slope = 3.0 * a_ * c**2 - b_
        good = ok & (c > 0.0) & (np.abs(slope) > 1e-3 * (3.0 * a_ * c**2 + np.abs(b_)))
        c = np.where(good, c - (a_ * c**3 - b_ * c - q_) / slope, c)
    return np.asarray(c, dtype=np.float64)


def piston_law_coefficients(D: float, L: float) -> tuple[float, float]:
    """``(a·μ/ΔP, b/ẋ)`` of the piston law, read off :func:`piston_leakage_flow`.

    Parameters
    ----------
    D, L
        Bore diameter and seal length [m].

    Returns
    -------
    tuple of float
        ``π·D/(12·L)`` [-] and ``π·D/2`` [m]: the law is ``(a·μ/ΔP)·ΔP/μ·c³ − (b/ẋ)·ẋ·c``.
    """
    a_unit = piston_leakage_flow(1.0, 0.0, 1.0, D, L, 1.0)
    b_unit = -piston_leakage_flow(0.0, 1.0, 1.0, D, L, 1.0)
    return float(a_unit), float(b_unit)


def spool_law_coefficient(Dv: float, Ls: float) -> float:
    """``Q·μ/(ΔP·cv³) = π·Dv/(12·Ls)`` [-] of the spool law, read off
    :func:`spool_leakage_flow` (``Dv``, ``Ls`` [m])."""
    return float(spool_leakage_flow(1.0, 1.0, Dv, Ls, 1.0))


def piston_clearance(q: float, dp: float, v: float, D: float, L: float, mu: float) -> float:
    """Clearance [m] that makes :func:`piston_leakage_flow` equal ``q``: the exact inverse on
    the rising branch of the law (:func:`leakage_root`); where the piston's drag outweighs
    its leak two clearances give ``q``, and this is the larger
    (:func:`diagnostics.inversion.cylinder_clearance` gives both).

    Parameters
    ----------
    q
        Leakage chamber 1 → 2, relative to the piston [m³/s].
    dp
        P1 − P2 [Pa], non-zero.
    v
        Piston velocity [m/s], positive towards chamber 2.
    D, L
        Bore diameter and seal length [m].
    mu
        Dynamic viscosity [Pa·s].

    Raises
    ------
    InputError
        When no positive clearance gives ``q`` (see :func:`leakage_root`).
    """
    if dp == 0.0:
        raise InputError("the clearance is undetermined without a pressure difference",
                         field="dp")
    s = 1.0 if dp > 0.0 else -1.0  # the law is odd in (q, dp, v): flip to dp > 0
    a_unit, b_unit = piston_law_coefficients(D, L)
    a, b = a_unit * s * dp / mu, b_unit * s * v
    c = float(leakage_root(a, b, s * q)[()])
    residual = a * c**3 - b * c - s * q
    if abs(residual) > 1e-9 * max(abs(q), abs(b) * c, a * c**3):
        raise InputError(f"no clearance gives a leakage of {q:.4g} m³/s", field="q")
    return c


def spool_clearance(q: float, dp: float, Dv: float, Ls: float, mu: float) -> float:
    """Clearance [m] that makes :func:`spool_leakage_flow` equal ``q``: the cube root of
    paper 002 eq. 23, ``cv = (12·μ·Ls·q/(π·Dv·ΔP))^(1/3)`` (exact inverse).

    Parameters
    ----------
    q
        Spool leakage P → T [m³/s], ≥ 0.
    dp
        Pressure difference across the lands, P_P − P_T [Pa], > 0.
    Dv, Ls
        Spool diameter and sealing length of the lands [m].
    mu
        Dynamic viscosity [Pa·s].

    Raises
    ------
    InputError
        A negative leakage or a pressure difference that is not positive (``field`` ``q``
        or ``dp``).
    """
    if not (q >= 0.0 and dp > 0.0):
        raise InputError("the spool law needs q ≥ 0 and ΔP > 0", field="q" if dp > 0 else "dp")
    return float(np.cbrt(q * mu / (spool_law_coefficient(Dv, Ls) * dp)))
