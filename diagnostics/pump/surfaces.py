"""Weighted polynomial fits of a loss coefficient over pressure and speed.

Paper 000 fits each loss coefficient against pressure (§4, "polynomial adjustments of the
values versus pressure") and recommends surfaces in pressure *and* speed (§6).  Here a
coefficient's point estimates ``c_k`` at ``(Δp_k, ω_k)`` with standard errors ``s_k`` are
fitted by weighted least squares (weights 1/s_k²) with
:class:`sim.components.gear_pump.CoefficientSurface`'s basis ``xⁱ·yʲ``.

The covariance of the polynomial coefficients is ``(XᵀWX)⁻¹`` scaled by the reduced χ² when
that exceeds 1 (the usual guard when the stated instrument errors are optimistic; with a
correct noise model χ²_red ≈ 1).  Pointwise estimates of different coefficients come from
the same readings and are correlated; each surface's covariance ignores that.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numpy.polynomial import polynomial as npoly
from scipy import stats

from sim.components.gear_pump import OMEGA_REF, P_REF, CoefficientSurface
from sim.errors import InputError

__all__ = ["SurfaceFit", "default_degrees", "fit_surface"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class SurfaceFit:
    """A fitted coefficient surface with its uncertainty and residuals.

    Attributes
    ----------
    name
        Coefficient name (``"Cs"``, ``"Cst"``, ``"Cv"``, ``"Cf"``).
    surface
        The fitted surface [-].
    cov
        Covariance of ``surface.coef.ravel()`` [-²].
    dp, omega, values, std
        The point estimates that were fitted: pressure rise [Pa], speed [rad/s], value and
        standard error [-].
    residual_rms, residual_max
        RMS and largest absolute residual of the point estimates [-].
    r2
        Weighted coefficient of determination [-]; NaN where the values do not vary
        beyond round-off (nothing for a surface to explain).
    chi2_red
        Reduced χ² of the weighted residuals [-] (≈ 1 when the noise model is right).
    constant, constant_std
        The weighted mean of the point estimates and its standard error [-]: the
        coefficient read as one number, as an engineer quotes it.
    varies_p
        p-value of the F-test of the surface against that constant [-]: small where the
        coefficient changes with pressure and speed beyond the noise; NaN for a constant
        surface.  A cubic surface through the noise of a constant coefficient swings by
        its standard errors (a pump maker's pass: Cs from 0.6 to 2.1 × its true
        constant); this says whether the swing is more than that.
    """

    name: str
    surface: CoefficientSurface
    cov: FloatArray
    dp: FloatArray
    omega: FloatArray
    values: FloatArray
    std: FloatArray
    residual_rms: float
    residual_max: float
    r2: float
    chi2_red: float
    constant: float = math.nan
    constant_std: float = math.nan
    varies_p: float = math.nan

    def with_cov(self, cov: FloatArray, constant_var: float) -> SurfaceFit:
        """This fit with ``cov`` and the constant's variance ``constant_var`` [-²]
        (a systematic error added: the derived capacity's)."""
        return dataclasses.replace(self, cov=cov, constant_std=math.sqrt(constant_var))

    def negative(self) -> str | None:
        """Where the surface is below zero at the fitted points (a slip, leakage or
        friction coefficient cannot be), or ``None``: how many, the lowest value and
        where, and whether it is beyond twice its standard error."""
        values = np.asarray(self.surface(self.dp, self.omega), dtype=np.float64)
        below = values < 0.0
        if not below.any():
            return None
        k = int(np.argmin(values))
        se = float(self.std_at(self.dp[k], self.omega[k]))
        beyond = values[k] + 2.0 * se < 0.0
        return (f"{self.name} surface below zero at {int(below.sum())} of {values.size} set "
                f"points (down to {values[k]:.3g} at {self.dp[k] / 1e5:.4g} bar, "
                f"{self.omega[k] * 30.0 / math.pi:.4g} rpm, standard error {se:.2g}): "
                + ("beyond twice its standard error, which the model cannot explain (check "
                   "the readings there)" if beyond else
                   "within twice its standard error, i.e. zero within the noise; a negative "
                   "coefficient is not physical"))

    def _basis(self, dp: npt.ArrayLike, omega: npt.ArrayLike) -> FloatArray:
        s = self.surface
        x, y = np.broadcast_arrays(np.asarray(dp, dtype=np.float64) / s.p_ref,
                                   np.asarray(omega, dtype=np.float64) / s.omega_ref)
        return np.asarray(npoly.polyvander2d(x.ravel(), y.ravel(), list(s.degrees)))

    def std_at(self, dp: npt.ArrayLike, omega: npt.ArrayLike) -> FloatArray:
        """Standard error of the fitted surface [-] at ``dp`` [Pa], ``omega`` [rad/s]."""
        shape = np.broadcast_shapes(np.shape(dp), np.shape(omega))
        V = self._basis(dp, omega)
        var = np.einsum("ij,jk,ik->i", V, self.cov, V)
        return np.sqrt(np.maximum(var, 0.0)).reshape(shape)


def default_degrees(dp: npt.ArrayLike, omega: npt.ArrayLike, *, p_ref: float = P_REF,
                    omega_ref: float = OMEGA_REF, most: int = 3) -> tuple[int, int]:
    """Surface degrees (pressure, speed) a bench's set points can carry: at most ``most``
    (the cubic surface of paper 000 §6), below the number of levels of each variable, and lowered
    (the higher first) until the points outnumber the coefficients.  A common 3-speed ×
    5-pressure bench was refused for 16 cubic coefficients with 15 points, with no way to
    ask for less (a pump field engineer's pass)."""
    x = np.unique(np.round(np.asarray(dp, dtype=np.float64).ravel() / p_ref, 3))
    y = np.unique(np.round(np.asarray(omega, dtype=np.float64).ravel() / omega_ref, 3))
    n = int(np.asarray(dp).size)
    dp_deg, n_deg = max(min(most, x.size - 1), 0), max(min(most, y.size - 1), 0)
    while (dp_deg + 1) * (n_deg + 1) >= n and (dp_deg or n_deg):
        if dp_deg >= n_deg:
            dp_deg -= 1
        else:
            n_deg -= 1
    return dp_deg, n_deg


def fit_surface(name: str, dp: npt.ArrayLike, omega: npt.ArrayLike, values: npt.ArrayLike,
                std: npt.ArrayLike | None = None, *, degrees: tuple[int, int] = (3, 3),
                p_ref: float = P_REF, omega_ref: float = OMEGA_REF) -> SurfaceFit:
    """Weighted least-squares polynomial surface through point estimates of a coefficient.

    Parameters
    ----------
    name
        Coefficient name, for messages.
    dp, omega
        Where the estimates hold: pressure rise [Pa], speed [rad/s].
    values
        Point estimates [-].
    std
        Their standard errors [-] (``None``: equal weights, covariance from the residuals).
    degrees
        Degrees (in pressure, in speed) [-].
    p_ref, omega_ref
        Scales of the surface variables [Pa], [rad/s].

    Returns
    -------
    SurfaceFit

    Raises
    ------
    InputError
        Too few points for the degrees (field ``name``), non-finite values or errors.
    """
    x = np.asarray(dp, dtype=np.float64).ravel() / p_ref
    y = np.asarray(omega, dtype=np.float64).ravel() / omega_ref
    v = np.asarray(values, dtype=np.float64).ravel()
    s = np.ones_like(v) if std is None else np.asarray(std, dtype=np.float64).ravel()
    dp_deg, n_deg = degrees
    m = (dp_deg + 1) * (n_deg + 1)
    if not (x.size == y.size == v.size == s.size):
        raise InputError("dp, omega, values and std differ in length", field=name)
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(s)) and np.all(s > 0)):
        raise InputError("point estimates and errors must be finite, errors > 0", field=name)
    if v.size <= m:
        raise InputError(f"{v.size} point estimates cannot fit {m} polynomial coefficients "
                         f"(degrees {degrees}); more set points or lower degrees", field=name)
    if np.unique(np.round(x, 3)).size <= dp_deg or np.unique(np.round(y, 3)).size <= n_deg:
        raise InputError(f"need more than {dp_deg} pressure and {n_deg} speed levels",
                         field=name)
    V = np.asarray(npoly.polyvander2d(x, y, [dp_deg, n_deg]))
    w = 1.0 / s
    A = V * w[:, None]
    sol, *_ = np.linalg.lstsq(A, v * w, rcond=None)
    coef = np.asarray(sol, dtype=np.float64)
    fitted = V @ coef
    res = v - fitted
    chi2_red = float(np.sum((res * w) ** 2) / (v.size - m))
    cov = np.asarray(np.linalg.inv(A.T @ A), dtype=np.float64)
    if std is None:
        cov *= chi2_red
    else:
        cov *= max(1.0, chi2_red)
    wmean = float(np.sum(v * w**2) / np.sum(w**2))
    ss_tot = float(np.sum(((v - wmean) * w) ** 2))
    # values constant to round-off (noise-free data of constant coefficients): R² would
    # compare round-off with round-off (a perfect fit read −85 in a user pass), so none
    constant = float(np.max(np.abs(v - wmean))) <= 1e-9 * abs(wmean)
    r2 = 1.0 - float(np.sum((res * w) ** 2)) / ss_tot if ss_tot > 0 and not constant \
        else math.nan
    surface = CoefficientSurface(coef.reshape(dp_deg + 1, n_deg + 1), p_ref, omega_ref)
    # the coefficient as one number: the weighted mean, its error scaled as the surface's
    chi2_red0 = ss_tot / (v.size - 1)
    constant_var = (chi2_red0 if std is None else max(1.0, chi2_red0)) / float(np.sum(w**2))
    rss = float(np.sum((res * w) ** 2))
    varies_p = math.nan
    if m > 1 and rss > 0 and not constant:
        F = ((ss_tot - rss) / (m - 1)) / (rss / (v.size - m))
        varies_p = float(stats.f.sf(F, m - 1, v.size - m))
    return SurfaceFit(
        name=name, surface=surface, cov=cov, dp=x * p_ref, omega=y * omega_ref, values=v,
        std=s, residual_rms=float(np.sqrt(np.mean(res**2))),
        residual_max=float(np.max(np.abs(res))), r2=r2, chi2_red=chi2_red,
        constant=wmean, constant_std=math.sqrt(constant_var), varies_p=varies_p,
    )
