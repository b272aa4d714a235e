"""Robust scatter: the normal-consistent median absolute deviation.

σ̂ = 1.4826 · median|x − median(x)| (Rousseeuw & Croux, *J. Am. Stat. Assoc.* 88, 1993,
1273-1283: the factor 1/Φ⁻¹(3/4) makes it the standard deviation of Gaussian data), which
one wrong reading in a few cannot move — the trend fits, the level-shift test and the ZeMA
leak sizes read their scatter by it.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["MAD_TO_SIGMA", "mad_sigma"]

#: 1/Φ⁻¹(3/4): the MAD of Gaussian data times this is its standard deviation [-]
MAD_TO_SIGMA = 1.4826


def mad_sigma(x: npt.ArrayLike) -> float:
    """σ̂ = 1.4826·median|x − median(x)| [unit of ``x``]; 0 for no values."""
    a = np.asarray(x, dtype=float)
    if a.size == 0:
        return 0.0
    return MAD_TO_SIGMA * float(np.median(np.abs(a - np.median(a))))
