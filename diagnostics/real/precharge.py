"""Accumulator pre-charge per cycle: where the accumulator stops storing oil, and how much it stores.

:mod:`~diagnostics.real.accumulator` reads a gas index ``A = V0·p0^(1/n)`` from the upper
load steps, assuming both plateaus of each step lie above the pre-charge ``p0``.  On the
ZeMA rig that fails in hot oil: the gas warms with the oil, its pressure at the gas
temperature rises (``p0·T/T_ref``), and an accumulator filled to 130 bar stores almost
nothing between the lower plateaus (``make real-data``: 0.02 ml on the 142→152 bar step
where a 115 bar fill stores 28 ml) — it is *empty* there, and the upper step's volume no
longer follows ``A``.  That compresses the gas volumes of the high fills (measured 130/115
bar ratio 1.04 where the gas law gives 1.09).  Here the emptying itself is modelled.

A gas-loaded accumulator of volume ``V0`` and pre-charge ``p0`` (at the gas temperature)
holds gas ``V(p) = V0·min(1, (p0/p)^(1/n))`` (polytropic, ``p·V^n`` constant above ``p0``;
empty below — the accumulator-sizing relation of :mod:`~diagnostics.real.accumulator`), so a
step from ``p_a`` to ``p_b`` stores::

    ΔV = V(p_a) − V(p_b)                                                          [m³]

(zero when both lie below ``p0``).  ``V0`` is one number of the rig (one accumulator, the
campaign changes its fill); ``p0`` is one number per cycle.  :func:`fit_precharge` finds
``V0`` for the campaign and ``p0`` per cycle by least squares over each cycle's load steps
(a grid in ``p0``; for a given ``V0`` every cycle's best ``p0`` is independent, and the
sum of squares is a quadratic in ``V0`` per cycle and grid value).  Nothing is fitted with
labels.  :func:`refer_precharge` refers ``p0`` to the fill temperature (ideal gas).

The oil compressed in the line adds ``c·Δp`` to every step; fitted freely on the ZeMA
campaign ``c`` comes out negative (unphysical), so it is held at its bound 0.  ``n`` is
the module default of :mod:`~diagnostics.real.accumulator` (1.4, fixed before any
score; the residual hardly changes between 1.0 and 1.4, so the data do not fix it).

Two uses of the fit in the leak estimate (:mod:`~diagnostics.real.profile`):

* :func:`stored_rate`: while the pressure still drifts on a plateau the accumulator takes in
  (or gives out) ``d(V0 − V(p))/dt`` [m³/s], which a flowmeter downstream of the
  accumulator node misses (or reads on top); the time derivative of :func:`stored_volume`.
* :func:`cycle_precharges`: the pre-charge at the gas temperature for *every* cycle.  A
  cycle that left the load program has no four load steps and no fit of its own; it takes
  the pre-charge (referred to 20 °C) of the nearest cycle in record order that has one,
  moved to its own oil temperature.  The rule was fixed before any score and rests on the
  hardware: a pre-charge changes only when the accumulator is refilled or swapped, not
  from one 60 s cycle to the next.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.optimize import minimize_scalar

from diagnostics.real.accumulator import ABSOLUTE_ZERO, LoadStep
from sim.errors import InputError

__all__ = ["PrechargeFit", "cycle_precharges", "fit_precharge", "refer_precharge", "stored_rate",
           "stored_volume"]

Arr = npt.NDArray[np.float64]


def stored_volume(p_from: npt.ArrayLike, p_to: npt.ArrayLike, p0: npt.ArrayLike,
                  v0: float, n: float = 1.4) -> Arr:
    """Oil stored [m³] by an accumulator (``V0`` [m³], pre-charge ``p0`` [Pa]) over a step.

    ``V0·(min(1, (p0/p_from)^(1/n)) − min(1, (p0/p_to)^(1/n)))``: positive for a rise.
    """
    a, b, c = (np.asarray(x, dtype=np.float64) for x in (p_from, p_to, p0))
    return np.asarray(v0 * (np.minimum(1.0, (c / a) ** (1.0 / n))
                            - np.minimum(1.0, (c / b) ** (1.0 / n))), dtype=np.float64)


@dataclass(frozen=True)
class PrechargeFit:
    """Accumulator volume of the campaign and pre-charge per cycle (gas temperature).

    Attributes
    ----------
    v0
        Accumulator gas volume when empty [m³].
    p0
        Pre-charge at the gas temperature per cycle [Pa]; NaN where a cycle had no steps.
    rms
        Root-mean-square residual of the stored volumes [m³].
    at_grid_edge
        Cycles whose ``p0`` lies on the grid's end (not bracketed) [-].
    """

    v0: float
    p0: Arr
    rms: float
    at_grid_edge: int


def fit_precharge(steps: Sequence[Sequence[LoadStep] | None], *, n: float = 1.4,
                  p0_min: float = 50.0e5, p0_max: float = 250.0e5,
                  resolution: float = 0.25e5) -> PrechargeFit:
    """``V0`` [m³] and ``p0`` [Pa] per cycle from the load steps of every cycle (module docstring).

    Parameters
    ----------
    steps
        Per cycle its load steps (:func:`~diagnostics.real.accumulator.step_volumes`), or
        None (or empty) for a cycle left out.
    n
        Polytropic exponent [-].
    p0_min, p0_max, resolution
        Grid of pre-charges [Pa].

    Raises
    ------
    InputError
        Fewer than 3 cycles with steps, cycles with different numbers of steps, or a bad grid.
    """
    if not (0 < p0_min < p0_max and resolution > 0 and n > 0):
        raise InputError("the pre-charge grid needs 0 < p0_min < p0_max, resolution > 0 and "
                         "n > 0", field="p0_min")
    used = [i for i, s in enumerate(steps) if s]
    if len(used) < 3:
        raise InputError("the pre-charge fit needs at least 3 cycles with load steps",
                         field="steps")
    counts = {len(steps[i] or ()) for i in used}
    if len(counts) != 1:
        raise InputError(f"cycles have different numbers of load steps {sorted(counts)}",
                         field="steps")
    pa = np.array([[s.p_from for s in steps[i] or ()] for i in used])
    pb = np.array([[s.p_to for s in steps[i] or ()] for i in used])
    dv = np.array([[s.volume for s in steps[i] or ()] for i in used])
    grid = np.arange(p0_min, p0_max + 0.5 * resolution, resolution)
    u = stored_volume(pa[:, None, :], pb[:, None, :], grid[None, :, None], 1.0, n)
    a = np.sum(dv * dv, axis=1)[:, None]
    b = np.sum(dv[:, None, :] * u, axis=2)
    c = np.sum(u * u, axis=2)

    def sse(v0: float) -> tuple[float, npt.NDArray[np.intp]]:
        s = a - 2.0 * v0 * b + v0 * v0 * c
        j = np.argmin(s, axis=1)
        return float(np.sum(s[np.arange(j.size), j])), j

    # a coarse scan over V0 (log-spaced, 0.1 ml … 100 l), then a bracketed refinement
    logs = np.linspace(np.log(1e-7), np.log(1e-1), 121)
    vals = [sse(float(np.exp(x)))[0] for x in logs]
    k = int(np.clip(np.argmin(vals), 1, logs.size - 2))
    res = minimize_scalar(lambda x: sse(float(np.exp(x)))[0],
                          bracket=(logs[k - 1], logs[k], logs[k + 1]))
    v0 = float(np.exp(res.x))
    total, j = sse(v0)
    p0 = np.full(len(steps), np.nan)
    p0[used] = grid[j]
    edge = int(np.sum((j == 0) | (j == grid.size - 1)))
    return PrechargeFit(v0, p0, float(np.sqrt(total / dv.size)), edge)


def refer_precharge(p0: npt.ArrayLike, theta: npt.ArrayLike, theta_ref: float = 20.0) -> Arr:
    """Pre-charge [Pa] at the fill temperature ``theta_ref`` [°C] from ``p0`` at ``theta`` [°C].

    Ideal gas at constant volume: ``p0·(theta_ref + 273.15)/(theta + 273.15)``.
    """
    t = np.asarray(theta, dtype=np.float64) + ABSOLUTE_ZERO
    return np.asarray(np.asarray(p0, dtype=np.float64) * (theta_ref + ABSOLUTE_ZERO) / t,
                      dtype=np.float64)


def stored_rate(p: npt.ArrayLike, p0: float, v0: float, rate: float, n: float = 1.4) -> Arr:
    """Oil flow into the accumulator [m³/s] at each sample of one plateau, from its pressure.

    ``(S(p_{k+1}) − S(p_{k−1}))/((k+1 − (k−1))·Δt)`` with ``S`` the oil stored
    (:func:`stored_volume`), central inside the plateau and one-sided at its two ends (the
    samples beyond belong to the transitions), so a steady pressure gives zero.

    Parameters
    ----------
    p
        Pressure samples of one plateau [Pa], uniformly spaced.
    p0
        Pre-charge at the gas temperature [Pa].
    v0
        Accumulator gas volume when empty [m³].
    rate
        Sample rate [Hz].
    n
        Polytropic exponent [-].

    Raises
    ------
    InputError
        Fewer than 2 samples, a rate ≤ 0, or a non-finite ``p0``/``v0``.
    """
    x = np.asarray(p, dtype=np.float64)
    if x.size < 2:
        raise InputError("a stored-volume rate needs at least 2 samples", field="p")
    if not (rate > 0 and np.isfinite(p0) and p0 > 0 and np.isfinite(v0) and v0 >= 0):
        raise InputError(f"the stored-volume rate needs rate > 0, p0 > 0 and V0 ≥ 0 (got "
                         f"{rate}, {p0}, {v0})", field="precharge")
    k = np.arange(x.size)
    lo, hi = np.maximum(k - 1, 0), np.minimum(k + 1, x.size - 1)
    return np.asarray(stored_volume(x[lo], x[hi], p0, v0, n) * rate / (hi - lo),
                      dtype=np.float64)


def cycle_precharges(p0: npt.ArrayLike, theta: npt.ArrayLike, theta_ref: float = 20.0) -> Arr:
    """Pre-charge at the gas temperature [Pa] for every cycle (module docstring).

    Parameters
    ----------
    p0
        Fitted pre-charge at the gas temperature per cycle, in record order [Pa]; NaN where a
        cycle had no fit.
    theta
        Oil (gas) temperature per cycle [°C], the one the fit's ``p0`` was taken at.
    theta_ref
        Fill temperature the neighbour's pre-charge is referred through [°C].

    Raises
    ------
    InputError
        Shapes differ, or no cycle has a fitted pre-charge.
    """
    a = np.asarray(p0, dtype=np.float64)
    t = np.asarray(theta, dtype=np.float64)
    if a.shape != t.shape or a.ndim != 1:
        raise InputError("pre-charges and temperatures differ in shape", field="precharge")
    have = np.flatnonzero(np.isfinite(a))
    if have.size == 0:
        raise InputError("no cycle has a fitted pre-charge", field="precharge")
    idx = np.arange(a.size)
    after = np.clip(np.searchsorted(have, idx), 0, have.size - 1)
    before = np.clip(after - 1, 0, have.size - 1)
    near = np.where(np.abs(have[before] - idx) <= np.abs(have[after] - idx),
                    have[before], have[after])
    p20 = refer_precharge(a[near], t[near], theta_ref)
    moved = p20 * (t + ABSOLUTE_ZERO) / (theta_ref + ABSOLUTE_ZERO)
    return np.asarray(np.where(np.isfinite(a), a, moved), dtype=np.float64)
