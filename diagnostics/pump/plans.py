"""Test plans over pressure and speed: Latin hypercube and orthogonal (factorial), paper 001.

* **Orthogonal plan** (paper 001 §1.4, §2.1): full factorial grid, ``n_p`` equally spaced
  pressure levels × ``n_w`` speed levels, extremes included.
* **Latin hypercube plan** (paper 001 §1.6): each factor's range cut into N strata of equal
  probability (uniform), one value drawn at random inside each stratum, the factors paired
  at random (scipy.stats.qmc.LatinHypercube, seeded).  Every sample sits in its own stratum of
  each factor, so a plan of N points tests N distinct pressures and N distinct speeds.

Both give set points (Δp [Pa], ω [rad/s]); temperature is a block factor (each plan is run
at each oil temperature), as paper 001 blocks slow factors.  Paper 001 added four
high-speed, high-pressure points to both plans to hold the boundary (``corner_points``).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.stats import qmc

from sim.errors import InputError

__all__ = ["latin_hypercube_plan", "orthogonal_plan"]

FloatArray = npt.NDArray[np.float64]


def _check_range(r: tuple[float, float], field: str) -> None:
    if not (np.isfinite(r[0]) and np.isfinite(r[1]) and 0 <= r[0] < r[1]):
        raise InputError(f"range {r} must be finite with 0 ≤ low < high", field=field)


def _corners(k: int, p_range: tuple[float, float], w_range: tuple[float, float]
             ) -> tuple[FloatArray, FloatArray]:
    """``k`` points in the high-pressure, high-speed corner (top 10 % of both ranges)."""
    if k <= 0:
        return np.zeros(0), np.zeros(0)
    f = np.linspace(0.9, 1.0, k)
    return (p_range[0] + f * (p_range[1] - p_range[0]),
            w_range[0] + f[::-1] * (w_range[1] - w_range[0]))


def orthogonal_plan(n_p: int, n_w: int, p_range: tuple[float, float],
                    omega_range: tuple[float, float], *, corner_points: int = 0
                    ) -> tuple[FloatArray, FloatArray]:
    """Full factorial plan of ``n_p`` × ``n_w`` set points (+ ``corner_points``).

    Parameters
    ----------
    n_p, n_w
        Number of pressure and speed levels [-], ≥ 2.
    p_range
        Pressure-rise range [Pa].
    omega_range
        Speed range [rad/s].
    corner_points
        Extra points near the high-pressure, high-speed corner [-].

    Returns
    -------
    tuple of ndarray
        ``(dp [Pa], omega [rad/s])``.
    """
    if n_p < 2 or n_w < 2:
        raise InputError("an orthogonal plan needs ≥ 2 levels of each factor", field="n_p")
    _check_range(p_range, "p_range")
    _check_range(omega_range, "omega_range")
    pp, ww = np.meshgrid(np.linspace(*p_range, n_p), np.linspace(*omega_range, n_w))
    cp, cw = _corners(corner_points, p_range, omega_range)
    return np.concatenate([pp.ravel(), cp]), np.concatenate([ww.ravel(), cw])


def latin_hypercube_plan(n: int, p_range: tuple[float, float],
                         omega_range: tuple[float, float], *,
                         seed: int | np.random.Generator = 0, corner_points: int = 0
                         ) -> tuple[FloatArray, FloatArray]:
    """Latin hypercube plan of ``n`` set points (+ ``corner_points``), seeded.

    Parameters
    ----------
    n
        Number of strata (= points) [-], ≥ 2.
    p_range
        Pressure-rise range [Pa].
    omega_range
        Speed range [rad/s].
    seed
        Seed or generator (the plan is reproducible).
    corner_points
        Extra points near the high-pressure, high-speed corner [-].

    Returns
    -------
    tuple of ndarray
        ``(dp [Pa], omega [rad/s])``.
    """
    if n < 2:
        raise InputError("a Latin hypercube needs ≥ 2 points", field="n")
    if corner_points < 0:
        raise InputError("corner_points must be ≥ 0", field="corner_points")
    _check_range(p_range, "p_range")
    _check_range(omega_range, "omega_range")
    sampler = qmc.LatinHypercube(d=2, rng=seed)
    u = qmc.scale(sampler.random(n), [p_range[0], omega_range[0]], [p_range[1], omega_range[1]])
    cp, cw = _corners(corner_points, p_range, omega_range)
    return np.concatenate([u[:, 0], cp]), np.concatenate([u[:, 1], cw])
