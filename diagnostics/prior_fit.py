"""Levenberg-Marquardt on whitened residuals plus a Gaussian prior, the fit of
commissioning (:mod:`diagnostics.commissioning`) and of its conditional re-fits
(:mod:`diagnostics.commissioning_nuisance`).

Minimises ``Φ(z) = Σ r_i(z)² + Σ_j (z_j / s_j)²`` over the ``free`` coordinates of z (the
others held), z = ln(θ/θ₀) with prior ``z_j ~ N(0, s_j²)``; z is kept within
±4 s_j.  Forward-difference Jacobian of step 1e-5 in z; the damping divided by 10 on a
step that lowers Φ and multiplied by 10 on one that does not (or where the rig has no
steady point, :class:`~sim.errors.SimulationError`); converged when a step moves z by
< 1e-5 or lowers Φ by < 1e-6 of Φ (of 1 when Φ < 1).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from sim.errors import SimulationError

__all__ = ["fit_with_prior"]

Arr = npt.NDArray[np.float64]

#: forward-difference step of the Jacobian in z [-]
STEP = 1e-5


def _jacobian(residuals: Callable[[Arr], Arr], z: Arr, r: Arr, free: Sequence[int]) -> Arr:
    jac = np.empty((r.size, len(free)))
    for c, j in enumerate(free):
        zj = z.copy()
        zj[j] += STEP
        jac[:, c] = (residuals(zj) - r) / STEP
    return jac


def fit_with_prior(residuals: Callable[[Arr], Arr], s: Arr, z: Arr,
                   free: Sequence[int] | None = None, max_iterations: int = 30
                   ) -> tuple[Arr, Arr, Arr, int]:
    """Fit the ``free`` coordinates of ``z`` (all by default) from ``z`` (module
    docstring); returns (z, the data residuals there, their Jacobian in the free
    coordinates, the iterations taken).

    Raises
    ------
    SimulationError
        The rig has no steady point at the start.
    """
    idx = list(range(z.size)) if free is None else list(free)
    sf = s[idx]
    z = z.copy()
    r = residuals(z)
    cost = float(r @ r + np.sum((z[idx] / sf) ** 2))
    lam = 1e-3
    jac = _jacobian(residuals, z, r, idx)
    its = 0
    for its in range(1, max_iterations + 1):  # noqa: B007 - its reported
        g = jac.T @ r + z[idx] / sf**2
        h = jac.T @ jac + np.diag(1.0 / sf**2)
        improved = False
        while lam < 1e10:
            step = -np.linalg.solve(h + lam * np.diag(np.diag(h)), g)
            zn = z.copy()
            zn[idx] = np.clip(z[idx] + step, -4.0 * sf, 4.0 * sf)
            try:
                rn = residuals(zn)
            except SimulationError:
                lam *= 10.0
                continue
            cn = float(rn @ rn + np.sum((zn[idx] / sf) ** 2))
            if cn < cost:
                gain, moved = cost - cn, float(np.max(np.abs(zn[idx] - z[idx])))
                z, r, cost, lam = zn, rn, cn, max(lam / 10.0, 1e-9)
                improved = True
                break
            lam *= 10.0
        if not improved:
            break
        jac = _jacobian(residuals, z, r, idx)
        if moved < 1e-5 or gain < 1e-6 * max(cost, 1.0):
            break
    return z, r, jac, its
