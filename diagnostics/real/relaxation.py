"""Settled plateau flow: the flow a plateau tends to once the accumulator's gas has relaxed.

After a pressure step the gas of a gas-loaded accumulator has been compressed or expanded
nearly adiabatically; it then exchanges heat with its shell and moves towards the
isothermal volume, so for some seconds the accumulator still takes in (after a rise) or
gives out (after a fall) oil while the pressure is already steady.  A flowmeter downstream
of the accumulator node (FS1 on the ZeMA rig) reads the pump's flow plus that outflow.  The
outflow decays with the gas's thermal time constant ``τ`` (first-order heat exchange, the
thermal time-constant model of accumulator sizing; e.g. Pourmovahed & Otis, *J. Dyn. Sys.
Meas. Control* 112 (1990) 115; not a seed paper), so on a plateau::

    q(t) = q∞ + c·exp(−(t − t₀)/τ)                                           [m³/s]

and ``q∞`` is the flow of the pump and the circuit alone.  Its size depends on the gas
volume, i.e. on the pre-charge and on whether the accumulator is empty at that plateau
(hot gas of a high pre-charge holds more than the lowest plateaus), so the plain plateau
mean carries the accumulator state into a leak estimate.  :func:`settled_flow` fits ``q∞``
and ``c`` by linear least squares for a given ``τ``; ``τ`` itself is one number of the rig,
found without labels by :func:`diagnostics.real.shunt.fit_relaxation`.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sim.errors import InputError

__all__ = ["MAX_RELAXATION", "ZEMA_RELAXATION", "settled_flow"]

#: the ZeMA rig's plateau settling time ``τ`` [s], found without labels by
#: :func:`diagnostics.real.shunt.fit_relaxation` over all 2205 cycles (``make real-data``)
ZEMA_RELAXATION = 3.5
#: Longest settling time a plateau may be given [s]: the ZeMA load program's plateaus last
#: 10-20 s, a relaxation past a minute leaves no plateau to read
MAX_RELAXATION = 60.0


def settled_flow(q: npt.ArrayLike, tau: float) -> float:
    """``q∞`` [m³/s] of ``q(k) = q∞ + c·exp(−k/tau)`` over the samples k = 0, 1, … of a plateau.

    Parameters
    ----------
    q
        Flow samples of one plateau [m³/s], uniformly spaced.
    tau
        Relaxation time in samples [-] (seconds × sample rate); 0 gives the plain mean.

    Raises
    ------
    InputError
        ``tau`` negative or not finite, or fewer than 3 samples with ``tau`` > 0.
    """
    y = np.asarray(q, dtype=np.float64)
    if not (np.isfinite(tau) and tau >= 0):
        raise InputError(f"the relaxation time must be ≥ 0, got {tau}", field="relaxation")
    if tau == 0:
        return float(y.mean())
    if y.size < 3:
        raise InputError("a settled flow needs at least 3 samples", field="q")
    k = np.arange(y.size, dtype=np.float64)
    x = np.column_stack([np.ones_like(k), np.exp(-k / tau)])
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    return float(coef[0])
