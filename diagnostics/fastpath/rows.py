"""A fault parameter's rows in graph values, as the fast path's compiled solves read them:
its :class:`Transform` (fitting coordinate → graph value, one proportional or inverse law)
and the rows of parameter vectors a map piece or a grid solves (:mod:`diagnostics.
fastpath.maps`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.hypotheses import FaultParameter
from diagnostics.signatures import GRAPH_PARAMETERS
from sim.rigs import Rig

__all__ = ["Transform", "piece_rows", "rows_at", "set_rows", "transform"]

Arr = npt.NDArray[np.float64]
IArr = npt.NDArray[np.int64]

#: per rig and fault parameter, its :class:`Transform`
_TRANSFORMS: dict[tuple[int, str], tuple[Rig, Transform | None]] = {}


@dataclass(frozen=True)
class Transform:
    """Fitting coordinate → graph parameter of a fault parameter, in numbers the kernel
    reads: ``g = c·v`` (mode 0) or ``c/v`` (mode 1), ``v = exp(z)`` if ``log`` else ``z``."""

    index: int
    log: bool
    mode: int
    const: float

    def graph(self, z: Arr) -> Arr:
        """Graph values [SI] at fitting coordinates ``z``."""
        v = np.exp(z) if self.log else np.asarray(z, dtype=np.float64)
        return np.asarray(self.const * v if self.mode == 0 else self.const / v)


def transform(rig: Rig, p: FaultParameter) -> Transform | None:
    """The :class:`Transform` of ``p`` read off :meth:`FaultParameter.graph_value` (one
    proportional or inverse law), or None when it is neither (then the direct path runs);
    kept per rig (a plain dict: the pair fits ask for it at every fit)."""
    key = (id(rig), p.name)
    hit = _TRANSFORMS.get(key)
    if hit is None or hit[0] is not rig:
        if len(_TRANSFORMS) > 256:
            _TRANSFORMS.clear()
        hit = (rig, _transform(rig, p))
        _TRANSFORMS[key] = hit
    return hit[1]


def _transform(rig: Rig, p: FaultParameter) -> Transform | None:
    g1, g2 = p.graph_value(rig, 1.0), p.graph_value(rig, 2.0)
    index = GRAPH_PARAMETERS.index(p.graph_param)
    if g1 != 0.0 and math.isclose(g2, 2.0 * g1, rel_tol=1e-12):
        return Transform(index, p.log, 0, g1)
    if g1 != 0.0 and math.isclose(g2, 0.5 * g1, rel_tol=1e-12):
        return Transform(index, p.log, 1, g1)
    return None


def rows_at(rig: Rig, p: FaultParameter, base: Arr, zs: Arr) -> Arr:
    """Graph values with ``p`` at fitting coordinates ``zs``, the others at ``base``."""
    g = np.tile(base, (zs.size, 1))
    set_rows(rig, p, g, zs)
    return g


def set_rows(rig: Rig, p: FaultParameter, g: Arr, zs: Arr) -> None:
    """Set ``p`` at fitting coordinates ``zs`` in the graph-value rows ``g`` (in place)."""
    tr = transform(rig, p)
    if tr is not None:
        g[:, tr.index] = tr.graph(zs)
    else:
        g[:, GRAPH_PARAMETERS.index(p.graph_param)] = [
            p.graph_value(rig, p.from_z(float(z))) for z in zs]


def piece_rows(rig: Rig, p: FaultParameter, base: Arr, lo: float, hi: float, n: int
                ) -> tuple[Arr, Arr, IArr]:
    """A map piece's coarse nodes ``zc`` (``n`` from ``lo`` to ``hi`` in fitting
    coordinates), the graph values of its rows and its run flags (1 at the first row)."""
    zc = np.linspace(lo, hi, n)
    return zc, rows_at(rig, p, base, zc), (np.arange(n) == 0).astype(np.int64)
