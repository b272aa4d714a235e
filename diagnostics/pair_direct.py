"""Two-parameter fits on direct solves: the reference numerics of a pair hypothesis.

One Python model evaluation (:meth:`diagnostics.signatures.SignatureMaps.predict`, both
phases' operating points by Newton) per residual vector.  The compiled fast path
(:mod:`diagnostics.fastpath.kernel`) runs the same iterations; the equivalence test
(``tests/diagnostics/test_fastpath.py``) holds them together.

* :func:`levenberg_marquardt` — from a start, forward-difference Jacobians of step 1e-6 of
  the range, the damping divided by 10 on success and multiplied by 10 on failure, at most
  15 iterations; converged when a step moves the estimate by < 1e-4 of its range or lowers
  χ² by < 1e-3;
* :func:`profile_points` — along the weak axis of a ridge, the strong parameter fitted by
  Gauss-Newton (4 steps at most): χ², curvature and position for
  :func:`diagnostics.ranking.profile_evidence`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from diagnostics.hypotheses import FaultParameter
from diagnostics.record_model import RecordModel
from diagnostics.signatures import OBSERVABLES
from sim.errors import SimulationError

__all__ = ["MASKED", "levenberg_marquardt", "profile_points", "residuals"]

Arr = npt.NDArray[np.float64]

#: normalised residual [σ] given to a reading whose prediction is masked in a direct solve
MASKED = 1.0e3


def residuals(models: Sequence[RecordModel], params: tuple[FaultParameter, ...], z: Arr
              ) -> tuple[Arr, list[Arr]]:
    """Whitened residuals of all records at fitting coordinates ``z``
    (:meth:`RecordModel.whitened`) and each record's predictions (NaN where no steady
    operating point exists).  A record with a masked reading falls back to its residuals
    per marginal σ, the masked reading counting ``MASKED`` σ."""
    vals = np.array([p.from_z(float(zz)) for p, zz in zip(params, z, strict=True)])
    rs, fulls = [], []
    for m in models:
        try:
            full = m.maps.predict(params, vals)
        except SimulationError:  # no steady operating point: masked
            full = np.full(len(OBSERVABLES), np.nan)
        fulls.append(full)
        resid = m.obs.values - full[m.idx]
        if np.isfinite(resid).all():
            rs.append(m.whitened(resid))
        else:  # a masked reading counts as a miss of MASKED σ: the fit steps away from it
            r = resid / m.sigma
            rs.append(np.where(np.isfinite(r), r, MASKED))
    return np.concatenate(rs), fulls


def levenberg_marquardt(models: Sequence[RecordModel], params: tuple[FaultParameter, ...],
                        z: Arr, zl: Arr, zu: Arr) -> tuple[Arr, float, Arr, list[Arr]]:
    """Levenberg-Marquardt from ``z`` on direct solves: ``(z, χ², last Jacobian,
    predictions)``; the Jacobian is by forward differences of 1e-6 of the range."""
    span = zu - zl
    r, fulls = residuals(models, params, z)
    cost = float(r @ r)
    lam = 1e-3
    jac = np.zeros((r.size, 2))
    for _ in range(15):
        for j in range(2):
            dz = 1e-6 * span[j]
            zj = z.copy()
            zj[j] = zj[j] + dz if zj[j] + dz <= zu[j] else zj[j] - dz
            rj, _ = residuals(models, params, zj)
            jac[:, j] = (rj - r) / (zj[j] - z[j])
        g = jac.T @ r
        h = jac.T @ jac
        improved = False
        while lam < 1e8:
            damped = h + lam * np.diag(np.diag(h) + 1e-30)
            step = -np.linalg.solve(damped, g)
            # a coordinate on its bound that the step pushes outward stays there, and the
            # other takes its own damped step (projected Levenberg-Marquardt): the clipped
            # full step stalled fits on a bound (a user pass: χ² 11 where 0.1 was a step
            # of the free coordinate away)
            out = ((z <= zl) & (step < 0)) | ((z >= zu) & (step > 0))
            if out.sum() == 1:
                free = int(np.flatnonzero(~out)[0])
                step = np.zeros(2)
                step[free] = -g[free] / damped[free, free]
            zn = np.clip(z + step, zl, zu)
            rn, fn = residuals(models, params, zn)
            cn = float(rn @ rn)
            if cn < cost:
                improved = True
                moved = float(np.max(np.abs(zn - z) / span))
                gain = cost - cn
                z, r, fulls, cost, lam = zn, rn, fn, cn, max(lam / 10.0, 1e-9)
                break
            lam *= 10.0
        # converged: the step moves the estimate by < 1e-4 of its range (a few 1e-5 of
        # a clearance) or no longer lowers χ² by a thousandth
        if not improved or moved < 1e-4 or gain < 1e-3:
            break
    return z, cost, jac, fulls


def profile_points(models: Sequence[RecordModel], params: tuple[FaultParameter, ...],
                   z_hat: Arr, slope: float, weak: int, grid: Arr, zl: Arr, zu: Arr
                   ) -> tuple[Arr, Arr, Arr]:
    """At each weak-axis point the strong parameter by Gauss-Newton (4 steps at most):
    χ², the curvature J·J and the strong coordinate, one array each."""
    strong = 1 - weak
    span = zu - zl
    n = grid.size
    chi2s, hss, zs = np.empty(n), np.empty(n), np.empty(n)
    z = z_hat.copy()
    for k, zw in enumerate(grid):
        z[weak] = zw
        z[strong] = float(np.clip(z_hat[strong] + slope * (zw - z_hat[weak]), zl[strong],
                                  zu[strong]))
        r, _ = residuals(models, params, z)
        h_ss = 0.0
        for _ in range(4):
            dz = 1e-6 * span[strong]
            zp = z.copy()
            zp[strong] = zp[strong] + dz if zp[strong] + dz <= zu[strong] else zp[strong] - dz
            rp, _ = residuals(models, params, zp)
            j = (rp - r) / (zp[strong] - z[strong])
            h_ss = float(j @ j)
            if h_ss <= 0:
                break
            zn = z.copy()
            zn[strong] = float(np.clip(z[strong] - float(j @ r) / h_ss, zl[strong],
                                       zu[strong]))
            rn, _ = residuals(models, params, zn)
            if float(rn @ rn) >= float(r @ r):
                break
            step = abs(zn[strong] - z[strong])
            z, r = zn, rn
            if step < 1e-4 * span[strong]:
                break
        chi2s[k], hss[k], zs[k] = float(r @ r), h_ss, z[strong]
    return chi2s, hss, zs
