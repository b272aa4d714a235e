"""Masked PCHIP of the fast path (source compiled into the rig's generated numba module,
:mod:`diagnostics.fastpath.compiled`, beside :mod:`diagnostics.fastpath.kernel`).

* :func:`pchip_columns` — masked PCHIP (Fritsch-Carlson slopes with scipy's end
  conditions, Fritsch & Carlson 1980, SIAM J. Numer. Anal. 17(2)), the interpolation of
  :func:`diagnostics.signatures.masked_pchip`;
* :func:`pchip_slopes` — its derivatives at the nodes.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["KERNELS", "pchip_columns", "pchip_slopes"]

#: names copied into the generated module, in dependency order
KERNELS = ("pchip_slopes", "pchip_columns")


def pchip_slopes(x, y, d):  # type: ignore[no-untyped-def]
    """PCHIP derivatives at the nodes (scipy's ``PchipInterpolator``: weighted harmonic
    means inside, the shape-preserving three-point formula at the ends)."""
    n = x.size
    if n == 2:
        d[0] = d[1] = (y[1] - y[0]) / (x[1] - x[0])
        return
    h = np.empty(n - 1)
    m = np.empty(n - 1)
    for k in range(n - 1):
        h[k] = x[k + 1] - x[k]
        m[k] = (y[k + 1] - y[k]) / h[k]
    for k in range(1, n - 1):
        if m[k - 1] * m[k] <= 0.0 or m[k - 1] == 0.0 or m[k] == 0.0:
            d[k] = 0.0
        else:
            w1 = 2.0 * h[k] + h[k - 1]
            w2 = h[k] + 2.0 * h[k - 1]
            d[k] = (w1 + w2) / (w1 / m[k - 1] + w2 / m[k])
    for end in range(2):
        h0 = h[0] if end == 0 else h[n - 2]
        h1 = h[1] if end == 0 else h[n - 3]
        m0 = m[0] if end == 0 else m[n - 2]
        m1 = m[1] if end == 0 else m[n - 3]
        dd = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
        if np.sign(dd) != np.sign(m0):
            dd = 0.0
        elif np.sign(m0) != np.sign(m1) and abs(dd) > abs(3.0 * m0):
            dd = 3.0 * m0
        d[0 if end == 0 else n - 1] = dd


def pchip_columns(xc, yc, xf, out):  # type: ignore[no-untyped-def]
    """Masked PCHIP of every column of ``yc`` (nodes ``xc``) at ``xf`` into ``out``: over
    the finite nodes only, NaN unless both nodes around a point are finite."""
    nc = xc.size
    # the coarse interval of each point (the same for every column)
    rights = np.empty(xf.size, dtype=np.int64)
    for i in range(xf.size):
        rights[i] = min(max(np.searchsorted(xc, xf[i]), 1), nc - 1)
    for j in range(yc.shape[1]):
        good = np.empty(nc, dtype=np.bool_)
        ng = 0
        for k in range(nc):
            good[k] = math.isfinite(yc[k, j])
            if good[k]:
                ng += 1
        if ng < 2:
            for i in range(xf.size):
                out[i, j] = np.nan
            continue
        x = np.empty(ng)
        y = np.empty(ng)
        q = 0
        for k in range(nc):
            if good[k]:
                x[q] = xc[k]
                y[q] = yc[k, j]
                q += 1
        d = np.empty(ng)
        pchip_slopes(x, y, d)
        seg = 0
        for i in range(xf.size):
            t = xf[i]
            right = rights[i]
            if not (good[right] and good[right - 1]):
                out[i, j] = np.nan
                continue
            while seg < ng - 2 and t > x[seg + 1]:
                seg += 1
            while seg > 0 and t < x[seg]:
                seg -= 1
            # the power form and summation order of scipy's PPoly (a flat piece stays
            # exactly flat: a plateau's argmax must not depend on round-off)
            hh = x[seg + 1] - x[seg]
            slope = (y[seg + 1] - y[seg]) / hh
            tt = (d[seg] + d[seg + 1] - 2.0 * slope) / hh
            c0 = tt / hh
            c1 = (slope - d[seg]) / hh - tt
            dx = t - x[seg]
            res = y[seg]
            zz = dx
            res += d[seg] * zz
            zz *= dx
            res += c1 * zz
            zz *= dx
            res += c0 * zz
            out[i, j] = res
