"""Accuracy in physical units: integration error as a fraction of the sensors' noise.

A simulated trace is compared with a measured one whose noise is σ per sensor; the
simulation's own error should be well below it.  :class:`NoiseAccuracy` states the target
per output (``fraction·σ`` in the output's unit); :func:`error_estimate` measures what a
run reached.

Estimate: the run at ``rtol`` is compared with a companion run at ``k·rtol`` (``k > 1``,
looser, cheaper) on the run's own output times.  RODAS4's global error is proportional to
the tolerance on the rigs (``make bench`` shows a decade of rtol giving a decade of error
against a converged reference), so ``e(k·rtol) ≈ k·e(rtol)`` and the difference of the
two runs is ``≈ (k − 1)·e(rtol)``; the estimate of the run's error is therefore
``max|y(rtol) − y(k·rtol)| / (k − 1)`` per output.  ``tests/sim/test_cycle_accuracy.py``
checks it against a converged run.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

__all__ = ["DEFAULT_FRACTIONS", "DEFAULT_NOISE", "NoiseAccuracy", "error_estimate"]

Arr = npt.NDArray[np.float64]

#: typical instrument noise σ by output unit (issue 17): velocity 3.2e-4 m/s, pressure
#: 25 kPa, flow 2.33e-6 m³/s; position 10 µm (a linear encoder / LVDT on the rod).
DEFAULT_NOISE: dict[str, float] = {"m/s": 3.2e-4, "Pa": 25e3, "m^3/s": 2.33e-6, "m": 1e-5}

#: default error target as a fraction of σ by unit (issue 17: velocity 0.3σ, pressure
#: and flow 0.1σ; position 0.1σ)
DEFAULT_FRACTIONS: dict[str, float] = {"m/s": 0.3, "Pa": 0.1, "m^3/s": 0.1, "m": 0.1}


@dataclass(frozen=True)
class NoiseAccuracy:
    """Error target of a simulation in units of sensor noise.

    Attributes
    ----------
    sigma
        Noise σ per output name [output unit]; outputs not named take
        :data:`DEFAULT_NOISE` of their unit, outputs whose unit has no default are not
        controlled.
    fraction
        Target error as a fraction of σ per output name [-]; outputs not named take
        :data:`DEFAULT_FRACTIONS` of their unit.
    """

    sigma: Mapping[str, float] = field(default_factory=dict)
    fraction: Mapping[str, float] = field(default_factory=dict)

    def targets(self, names: list[str], units: list[str]) -> dict[str, tuple[float, float]]:
        """``name → (σ [unit], fraction [-])`` of every controlled output."""
        out: dict[str, tuple[float, float]] = {}
        for name, unit in zip(names, units, strict=True):
            sig = self.sigma.get(name, DEFAULT_NOISE.get(unit))
            frac = self.fraction.get(name, DEFAULT_FRACTIONS.get(unit, 0.1))
            if sig is not None and sig > 0:
                out[name] = (float(sig), float(frac))
        return out


def error_estimate(main: list[tuple[Arr, Arr]], companion: list[tuple[Arr, Arr]],
                   ratio: float, names: list[str],
                   targets: Mapping[str, tuple[float, float]]) -> dict[str, float]:
    """Estimated error of ``main`` per controlled output, in units of its σ [-].

    Parameters
    ----------
    main, companion
        Per phase ``(times [s], outputs)`` of the run and of its companion at
        ``ratio·rtol``; the companion's times are a subset of the run's (it was sampled
        at them).  Times present in only one run (between the two runs' phase switches)
        are left out.
    ratio
        Companion tolerance / run tolerance, > 1 [-].
    names
        Output names (columns).
    targets
        ``name → (σ, fraction)``.
    """
    worst = np.zeros(len(names))
    for (tm, om), (tc, oc) in zip(main, companion, strict=True):
        if tc.size == 0 or tm.size == 0:  # a phase with no sample on the grid
            continue
        idx = np.searchsorted(tm, tc)
        ok = (idx < tm.size) & (tm[np.minimum(idx, tm.size - 1)] == tc)
        if not ok.any():
            continue
        diff = np.abs(om[idx[ok]] - oc[ok]).max(axis=0)
        worst = np.maximum(worst, diff)
    est = worst / (ratio - 1.0)
    return {n: float(est[j] / targets[n][0]) for j, n in enumerate(names) if n in targets}
