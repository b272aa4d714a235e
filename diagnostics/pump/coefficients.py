"""Loss coefficients Cs, Cst, Cv, Cf of paper 000 from ISO 4409 data at two temperatures.

Pairs of set points (same pressure and speed levels) at the coldest oil θ₁ (viscosity μ₁)
and the hottest θ₂ (μ₂) give, with the derived capacity D [m³/rad]:

* flow loss ``L = D·ω − q`` [m³/s] at each temperature;
* **Cs** (eq. 7): ``Cs = (L₂ − L₁) / (D·(Δp₂/μ₂ − Δp₁/μ₁))``.  With equal readings at both
  temperatures this is the paper's ``(q₁ − q₂)/(Δp·D·(1/μ₂ − 1/μ₁))``; written with the
  loss, a small difference of the actual speeds of the two runs (drive slip under a
  different load) does not enter as slip;
* **Cst** (eqs. 8-9): ``Qst = L − Cs·Δp·D/μ − Δp·D·ω/β_ef`` at each temperature, then
  ``Cst = Qst / √(2Δp·D^(4/3)/ρ)`` with eq. 9's exponent (eq. 5 of the copy prints D⁴,
  which is not dimensionless; see :mod:`sim.components.gear_pump`); mean of θ₁ and θ₂;
* torque loss ``TL = T − Δp·D`` [N·m];
* **Cv** (eq. 17): ``Cv = (TL₁ − TL₂) / (D·(μ₁ω₁ − μ₂ω₂))``, equal to the paper's
  ``(T₁ − T₂)/((μ₁ − μ₂)·ω·D)`` at equal readings;
* **Cf** (eqs. 18-19): ``Tf = T − Δp·D − Cv·μ·ω·D`` and ``Cf = Tf/(Δp·D)``; mean of θ₁ and
  θ₂.  The copy's eq. 18 reads ``Tf = T − Tv``; the ideal torque Δp·D (eq. 13) must also be
  removed, or Cf would be 1 + the friction coefficient.

The formulas above are those of equal readings at both temperatures.  The code solves each
pair's two runs together instead — ``L − Δp·D·ω/β = Cs·Δp·D/μ + Cst·√(2Δp·D^(4/3)/ρ)`` and
``TL = D·(Cv·μ·ω + Cf·Δp)`` at θ₁ and θ₂, two linear equations in two unknowns each — which
gives the same numbers at equal readings and stays exact when a run's pressure or speed
differs a little (a hot run 0.5 % off in pressure put Cf·D·(Δp₁ − Δp₂) into eq. 17's Cv).

β_ef and ρ are inputs: steady flow data cannot separate compressibility (Δp·ω) from a
speed-dependent slip (DISCREPANCY.md: identical columns on steady data), so β_ef is taken
from the oil, as paper 000 does.

Standard errors of the point estimates follow from the instrument accuracies
(:class:`diagnostics.pump.bench.InstrumentNoise`) by first-order propagation through the
formulas above (numerical derivatives), including the temperature readings through μ(θ).
A stated uncertainty of D adds, after the surface fit, a fully correlated term (the fit is
repeated with D ± its standard error).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.pump.bench import InstrumentNoise
from diagnostics.pump.capacity import THETA_GAP, CapacityEstimate, derived_capacity_toet
from diagnostics.pump.data import BenchData
from diagnostics.pump.levels import cluster_levels, group_keys
from diagnostics.pump.plausibility import check_displacement, check_torque
from diagnostics.pump.surfaces import SurfaceFit, default_degrees, fit_surface
from sim.components.gear_pump import GearPump, dynamic_viscosity
from sim.errors import InputError
from sim.fluid import Fluid

__all__ = ["PairedPoints", "PointEstimates", "PumpParameterisation", "pair_set_points",
           "parameterise", "point_coefficients"]

FloatArray = npt.NDArray[np.float64]

_INPUTS = ("dp1", "dp2", "w1", "w2", "q1", "q2", "t1", "t2", "th1", "th2")


@dataclass(frozen=True, eq=False)
class PairedPoints:
    """Set-point means at the cold (1) and hot (2) temperature, one row per set point.

    Attributes
    ----------
    values
        ``{"dp1", "dp2" [Pa], "w1", "w2" [rad/s], "q1", "q2" [m³/s], "t1", "t2" [N·m],
        "th1", "th2" [°C]}``; torque NaN when not measured.
    variances
        Variances of these means from the instrument accuracies (same keys, units²).
    """

    values: dict[str, FloatArray]
    variances: dict[str, FloatArray]
    has_torque: bool

    def __len__(self) -> int:
        return int(self.values["dp1"].size)


@dataclass(frozen=True, eq=False)
class PointEstimates:
    """Point estimates of the loss coefficients at each set point.

    Attributes
    ----------
    dp, omega
        Where they hold: mean pressure rise [Pa] and speed [rad/s] of the pair.
    values, std
        ``{"Cs", "Cst", "Cv", "Cf"}`` → estimates and standard errors [-].
    """

    dp: FloatArray
    omega: FloatArray
    values: dict[str, FloatArray]
    std: dict[str, FloatArray]


def pair_set_points(data: BenchData, noise: InstrumentNoise | None = None) -> PairedPoints:
    """Group readings into set points and pair the coldest and hottest temperature levels.

    Parameters
    ----------
    data
        Steady points of a grid plan run at ≥ 2 oil temperatures (levels ≥ 3 K apart).
    noise
        Instrument accuracies for the variances (default :class:`InstrumentNoise`).

    Raises
    ------
    InputError
        Fewer than two temperature levels (field ``theta``), or no set point present at both
        (field ``p_out``).
    """
    nz = noise if noise is not None else InstrumentNoise()
    t_idx, t_lev = cluster_levels(data.theta, rel_gap=0.0, abs_gap=THETA_GAP, field="theta")
    if t_lev.size < 2:
        raise InputError("eq. 7 and 17 need data at two oil temperatures (paper 000: 22 and "
                         "60 °C); found one level", field="theta")
    p_idx, _ = cluster_levels(data.dp, field="p_out")
    w_idx, _ = cluster_levels(data.omega, field="n")
    key = group_keys(p_idx, w_idx)
    cold, hot = 0, int(t_lev.size - 1)
    torque = data.torque
    vals: dict[str, list[float]] = {k: [] for k in _INPUTS}
    var: dict[str, list[float]] = {k: [] for k in _INPUTS}
    for k in np.unique(key):
        rows = [np.flatnonzero((key == k) & (t_idx == lev)) for lev in (cold, hot)]
        if rows[0].size == 0 or rows[1].size == 0:
            continue
        for tag, r in zip(("1", "2"), rows, strict=True):
            n = r.size
            dp = float(np.mean(data.dp[r]))
            w = float(np.mean(data.omega[r]))
            q = float(np.mean(data.q[r]))
            t = float(np.mean(torque[r])) if torque is not None else math.nan
            p_sq = float(np.mean(data.p_out[r] ** 2 + data.p_in[r] ** 2))
            vals["dp" + tag].append(dp)
            var["dp" + tag].append(nz.sigma("pressure") ** 2 * p_sq / n)
            vals["w" + tag].append(w)
            var["w" + tag].append((nz.sigma("speed") * w) ** 2 / n)
            vals["q" + tag].append(q)
            var["q" + tag].append(float(np.mean(nz.flow_sigma(data.q[r]) ** 2)) / n)
            vals["t" + tag].append(t)
            var["t" + tag].append((nz.sigma("torque") * t) ** 2 / n)
            vals["th" + tag].append(float(np.mean(data.theta[r])))
            var["th" + tag].append(nz.sigma("temperature") ** 2 / n)
    if not vals["dp1"]:
        raise InputError("no set point was run at both temperatures", field="p_out")
    return PairedPoints({k: np.asarray(v) for k, v in vals.items()},
                        {k: np.asarray(v) for k, v in var.items()}, torque is not None)


def _coefficients(x: Mapping[str, FloatArray], D: float, fluid: Fluid, rho: float,
                  beta_ef: float) -> dict[str, FloatArray]:
    """Eqs. 7-9 and 17-19 (module doc) on set-point means ``x`` (keys of ``_INPUTS``)."""
    mu1 = dynamic_viscosity(fluid, x["th1"])
    mu2 = dynamic_viscosity(fluid, x["th2"])
    out: dict[str, FloatArray] = {}
    # each run's loss less its compression (eq. 8's Δp·D·ω/β) is Cs·a + Cst·b (eqs. 6, 9),
    # two equations in two unknowns; solved as such, the runs' pressures and speeds need
    # not be equal (a bench never holds them exactly).  At equal readings this is eq. 7
    # and eq. 9 at each temperature, as the paper writes them
    r1 = D * x["w1"] - x["q1"] - x["dp1"] * D * x["w1"] / beta_ef
    r2 = D * x["w2"] - x["q2"] - x["dp2"] * D * x["w2"] / beta_ef
    a1, a2 = x["dp1"] * D / mu1, x["dp2"] * D / mu2
    b1 = np.sqrt(2.0 * x["dp1"] * D ** (4.0 / 3.0) / rho)
    b2 = np.sqrt(2.0 * x["dp2"] * D ** (4.0 / 3.0) / rho)
    det = a1 * b2 - a2 * b1
    out["Cs"] = (r1 * b2 - r2 * b1) / det                                   # eq. 7
    out["Cst"] = (a1 * r2 - a2 * r1) / det                                  # eqs. 8-9
    # likewise each run's torque loss T − Δp·D is D·(Cv·μ·ω + Cf·Δp) (eqs. 16-19): with
    # the cold run's pressure 0.5 % off the hot one's, eq. 17 alone put 3 % of Cf·Δp into
    # Cv at low speed (a user pass, by hand ≈ 920 of 3e4)
    tl1 = x["t1"] - x["dp1"] * D
    tl2 = x["t2"] - x["dp2"] * D
    c1, c2 = mu1 * x["w1"] * D, mu2 * x["w2"] * D
    e1, e2 = x["dp1"] * D, x["dp2"] * D
    det_t = c1 * e2 - c2 * e1
    out["Cv"] = (tl1 * e2 - tl2 * e1) / det_t                               # eq. 17
    out["Cf"] = (c1 * tl2 - c2 * tl1) / det_t                               # eqs. 18-19
    return out


def point_coefficients(pairs: PairedPoints, D: float, *, fluid: Fluid | None = None,
                       rho: float = 865.0, beta_ef: float = 1.5e9) -> PointEstimates:
    """Point estimates of Cs, Cst (and Cv, Cf with torque) with standard errors.

    Parameters
    ----------
    pairs
        From :func:`pair_set_points`.
    D
        Derived capacity [m³/rad].
    fluid
        Oil for μ(θ) (default :class:`sim.fluid.Fluid`, ISO VG 46).
    rho
        Density in eq. 9 [kg/m³].
    beta_ef
        Effective bulk modulus in eq. 8 [Pa].

    Returns
    -------
    PointEstimates
        At the mean pressure rise and speed of each pair.
    """
    if not (D > 0 and rho > 0 and beta_ef > 0):
        raise InputError("D, rho and beta_ef must be positive", field="D")
    fl = fluid if fluid is not None else Fluid()
    x = pairs.values
    base = _coefficients(x, D, fl, rho, beta_ef)
    var = {k: np.zeros_like(v) for k, v in base.items()}
    for name in _INPUTS:
        sd = np.sqrt(pairs.variances[name])
        if name.startswith("t") and not name.startswith("th") and not pairs.has_torque:
            continue
        h = np.where(sd > 0, sd, 1e-9 * np.maximum(np.abs(x[name]), 1.0))
        shifted = dict(x)
        shifted[name] = x[name] + h
        up = _coefficients(shifted, D, fl, rho, beta_ef)
        for k in base:
            var[k] += ((up[k] - base[k]) / h) ** 2 * pairs.variances[name]
    names = ("Cs", "Cst", "Cv", "Cf") if pairs.has_torque else ("Cs", "Cst")
    return PointEstimates(
        dp=0.5 * (x["dp1"] + x["dp2"]), omega=0.5 * (x["w1"] + x["w2"]),
        values={k: base[k] for k in names}, std={k: np.sqrt(var[k]) for k in names},
    )


@dataclass(frozen=True, eq=False)
class PumpParameterisation:
    """The result of :func:`parameterise`.

    Attributes
    ----------
    D, D_std
        Derived capacity used and its standard error [m³/rad].
    capacity
        The capacity estimate when it came from the data (Toet), else ``None``.
    points
        Point estimates of the coefficients; ``None`` in single-temperature mode.
    fits
        ``{"Cs", "Cst", "Cv", "Cf"}`` → surface fits (Cv, Cf only with torque); empty in
        single-temperature mode.
    rho, beta_ef
        Density [kg/m³] and bulk modulus [Pa] assumed.
    fluid
        The oil assumed for μ(θ).
    """

    D: float
    D_std: float
    capacity: CapacityEstimate | None
    points: PointEstimates | None
    fits: dict[str, SurfaceFit]
    rho: float
    beta_ef: float
    fluid: Fluid
    not_identifiable: str = ""

    def pump(self) -> GearPump:
        """A :class:`GearPump` with the fitted surfaces (needs Cv and Cf, i.e. torque data)."""
        if self.points is None:
            raise InputError(self.not_identifiable, field="theta")
        if "Cv" not in self.fits:
            raise InputError("no torque data: Cv and Cf were not parameterised", field="T")
        dp, w = self.points.dp, self.points.omega
        return GearPump(Cs=self.fits["Cs"].surface, Cst=self.fits["Cst"].surface,
                        Cv=self.fits["Cv"].surface, Cf=self.fits["Cf"].surface, D=self.D,
                        rho=self.rho, beta_ef=self.beta_ef, fluid=self.fluid,
                        p_range=(float(dp.min()), float(dp.max())),
                        omega_range=(float(w.min()), float(w.max())),
                        note="parameterised from bench data (paper 000 eqs. 7-9, 17-19)")


def _refuse_identical(pairs: PairedPoints) -> None:
    """Refuse pairs whose readings do not change with temperature at all (degenerate)."""
    x = pairs.values
    same_q = np.allclose(x["q1"], x["q2"], rtol=1e-9, atol=0.0)
    same_t = (not pairs.has_torque) or np.allclose(x["t1"], x["t2"], rtol=1e-9, atol=0.0)
    if same_q and same_t:
        raise InputError("the readings at the two oil temperatures are identical: eqs. 7 and "
                         "17 need flow and torque measured at each temperature (is one data "
                         "set labelled with two temperatures?); nothing was fitted",
                         field="theta")


def _fit_all(points: PointEstimates, degrees: Mapping[str, tuple[int, int]]
             ) -> dict[str, SurfaceFit]:
    out: dict[str, SurfaceFit] = {}
    for k, v in points.values.items():
        sd = points.std[k]
        out[k] = fit_surface(k, points.dp, points.omega, v, sd if np.any(sd > 0) else None,
                             degrees=degrees.get(k) or default_degrees(points.dp,
                                                                       points.omega))
    return out


def parameterise(data: BenchData, *, D: float | None = None, D_std: float = 0.0,
                 fluid: Fluid | None = None, rho: float = 865.0, beta_ef: float = 1.5e9,
                 degrees: Mapping[str, tuple[int, int]] | None = None,
                 noise: InstrumentNoise | None = None) -> PumpParameterisation:
    """Parameterise paper 000's loss model from ISO 4409 data at two temperatures.

    Parameters
    ----------
    data
        A grid plan (set points repeated at ≥ 2 oil temperatures), with torque for Cv, Cf.
    D
        Derived capacity [m³/rad]; ``None``: Toet method at the coldest oil
        (:func:`~diagnostics.pump.capacity.derived_capacity_toet`), with its standard error.
    D_std
        Standard error of a given ``D`` [m³/rad] (propagated as a systematic error).
    fluid
        Oil for μ(θ) (default ISO VG 46, :class:`sim.fluid.Fluid`).
    rho, beta_ef
        Density [kg/m³] and effective bulk modulus [Pa] (defaults as
        :data:`sim.components.gear_pump.PARAMETERS`).
    degrees
        Surface degrees (pressure, speed) per coefficient; default (3, 3) for each, the cubic
        surface of paper 000 §6, lowered where the set points cannot carry it
        (:func:`~diagnostics.pump.surfaces.default_degrees`).
    noise
        Instrument accuracies for the standard errors (default :class:`InstrumentNoise`).

    Returns
    -------
    PumpParameterisation
        With one oil-temperature level (most manufacturer maps) the *single-temperature
        mode*: the derived capacity only, ``fits`` empty and ``not_identifiable`` saying
        why eqs. 7-9 and 17-19 cannot be used (they need the flow and torque to change
        with viscosity at fixed Δp and ω).

    Raises
    ------
    InputError
        Degenerate data: the readings at the two temperatures are identical (one data
        set labelled twice, ``field="theta"``), or too few levels for the capacity;
        impossible data: a given ``D`` the flows contradict (``field="D"``) or torque
        below the ideal Δp·D (``field="T"``), :mod:`diagnostics.pump.plausibility`.
    """
    fl = fluid if fluid is not None else Fluid()
    _, t_lev = cluster_levels(data.theta, rel_gap=0.0, abs_gap=THETA_GAP, field="theta")
    capacity: CapacityEstimate | None = None
    if D is None:
        capacity = derived_capacity_toet(data)
        D, D_std = capacity.D, capacity.std if math.isfinite(capacity.std) else 0.0
        if not D > 0:
            raise InputError(
                f"the derived capacity (Toet, ISO 8426) comes out {D * 2e6 * math.pi:.4g} "
                "cm³/rev: the flow does not rise with speed as a pump's delivery does; is "
                "the flow column the case drain (the leakage) instead of the delivered "
                "flow, or its sign reversed?", field="q")
    if not (D > 0 and D_std >= 0):
        raise InputError("D must be > 0 and D_std ≥ 0", field="D")
    if capacity is None:
        check_displacement(data, D)
    check_torque(data, D, given=capacity is None)
    if t_lev.size < 2:
        reason = (f"Cs, Cst (eqs. 7-9) and Cv, Cf (eqs. 17-19) need data at two oil "
                  f"temperatures; the data "
                  f"have one level ({float(t_lev[0]):.1f} °C): not identifiable, only the "
                  "derived capacity is given")
        return PumpParameterisation(D=D, D_std=D_std, capacity=capacity, points=None, fits={},
                                    rho=rho, beta_ef=beta_ef, fluid=fl, not_identifiable=reason)
    deg = dict(degrees) if degrees is not None else {}
    pairs = pair_set_points(data, noise)
    _refuse_identical(pairs)
    points = point_coefficients(pairs, D, fluid=fl, rho=rho, beta_ef=beta_ef)
    fits = _fit_all(points, deg)
    if D_std > 0:
        hi = _fit_all(point_coefficients(pairs, D + D_std, fluid=fl, rho=rho,
                                         beta_ef=beta_ef), deg)
        lo = _fit_all(point_coefficients(pairs, D - D_std, fluid=fl, rho=rho,
                                         beta_ef=beta_ef), deg)
        for k, f in fits.items():
            g = 0.5 * (hi[k].surface.coef - lo[k].surface.coef).ravel()
            g0 = 0.5 * (hi[k].constant - lo[k].constant)
            fits[k] = f.with_cov(f.cov + np.outer(g, g), f.constant_std**2 + g0**2)
    return PumpParameterisation(D=D, D_std=D_std, capacity=capacity, points=points, fits=fits,
                                rho=rho, beta_ef=beta_ef, fluid=fl)
