"""Accumulator gas volume per load cycle from the oil it stores at each load step.

Between two steady working plateaus ``(p_i, q_i)`` and ``(p_j, q_j)`` of a constant load
cycle the pump keeps delivering its steady flow ``q_ss(p)`` (linear between the plateau
means), while the flowmeter downstream of the accumulator node reads ``q(t)``.  The
difference is oil stored in (rise) or released from (fall) the accumulator and the line::

    ΔV = Σ_k (q_ss(p_k) − q_k)·Δt                                          [m³]

Block means give the same sum as raw samples (it is an integral), so the 1 Hz ZeMA files
carry it exactly.  A gas-loaded accumulator with pre-charge ``p0`` and volume ``V0``,
compressed polytropically (``p·V^n`` constant) above ``p0``, stores::

    ΔV = V0·p0^(1/n) · (p_i^(−1/n) − p_j^(−1/n)) = A · Δg                   (polytropic)

(the polytropic gas law of accumulator sizing, p·V^n = const with n = 1.4 for fast
adiabatic steps; a textbook relation, e.g. Esposito, *Fluid Power with Applications*,
accumulator sizing — not one of the seed papers, which have no accumulator).

so every step gives the *gas index* ``A = V0·p0^(1/n)`` [m³·Pa^(1/n)], which grows with the
pre-charge for a given accumulator.  It is reported as the gas volume at a reference
pressure, ``V_gas(p_ref) = A·p_ref^(−1/n)`` [m³].  The oil's own compressibility in the
line (``V_line/β·Δp``) adds a constant share that is folded into ``A`` (Δg and Δp are
nearly proportional over a 10 bar step).  ``V0`` is not published for the ZeMA rig, so
``p0`` itself is not identifiable from one cycle; the gas volume orders pre-charges.

The pre-charge is set at one temperature, and the gas warms with the oil: at constant gas
volume ``p0(T) = p0·T/T_ref`` (ideal gas, absolute temperatures), so the same accumulator
looks larger in hot oil by ``(T/T_ref)^(1/n)``.  Given the oil temperature of the cycle,
:func:`gas_volume` refers the gas volume back to ``T_ref`` (nothing fitted).

Only steps whose both plateaus lie above the pre-charge follow the polytropic law; below
``p0`` the accumulator is empty and stores nothing.  The pre-charge is what is sought, so
the steps are chosen by a rule fixed before any score (:func:`upper_steps`, the default of
:func:`gas_volumes`): the steps whose both plateaus lie in the upper half of the cycle's
working plateau pressures, the ones furthest above any pre-charge.  On the ZeMA load program
(plateaus 146, 156, 166, 156, 151 bar) these are the rise and the fall between 156 and
166 bar.  Two label-free checks agree with the rule (``make real-data``): those two steps
give nearly the same gas volume cycle by cycle (rank correlation 0.85), while the steps
that touch the lower plateaus agree with each other (0.87) but hardly with the upper pair
(0.17-0.31), as steps partly below a hot pre-charge would (at 55 °C oil a 130 bar fill
charged at 20 °C holds 130·328/293 ≈ 146 bar).  The rule picks the same steps that an
earlier version had picked after seeing per-step scores, so its score is not a fresh test.

In hot oil a high fill's pressure at the gas temperature rises above the lower plateaus:
the accumulator is then empty there and the gas index of the upper steps reads low (the
130/115 bar ratio of the gas volumes is compressed).  :mod:`~diagnostics.real.precharge`
models that emptying and reads the pre-charge itself per cycle.

Defaults
--------
``n = 1.4`` [-]: adiabatic exponent of nitrogen, the usual choice for accumulator
transients shorter than a few seconds (chosen: the ZeMA load steps settle within ~1 s;
no thermal time constant is published).  ``p_ref = 150e5`` [Pa]: the middle of the ZeMA
load program's working plateaus (146-166 bar, SOURCE.md).  ``theta_ref = 20`` [°C]: the
temperature the pre-charge refers to (chosen: a workshop fill; not published).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from diagnostics.real.leakage import record_plateaus
from diagnostics.real.relaxation import settled_flow
from diagnostics.sampling import uniform_rate
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError, MeasurementError

__all__ = ["LoadStep", "gas_volume", "gas_volumes", "step_volumes", "upper_steps"]

Arr = npt.NDArray[np.float64]

#: 0 °C in kelvin [K].
ABSOLUTE_ZERO = 273.15


@dataclass(frozen=True, slots=True)
class LoadStep:
    """One step between adjacent working plateaus.

    Attributes
    ----------
    p_from, p_to
        Plateau pressures before and after [Pa].
    volume
        Oil stored during the step [m³] (negative: released).
    t
        Start of the transition [s from the record's start].
    """

    p_from: float
    p_to: float
    volume: float
    t: float

    def polytropic_term(self, n: float) -> float:
        """``Δg = p_from^(−1/n) − p_to^(−1/n)`` [Pa^(−1/n)]."""
        return float(self.p_from ** (-1.0 / n) - self.p_to ** (-1.0 / n))


def step_volumes(record: SeriesRecord, *, pressure: str = "p_pump", flow: str = "q_work",
                 min_flow_fraction: float = 0.2, max_gap: float = 4.0,
                 min_step: float = 2.0e5, relaxation: float = 0.0,
                 **plateau_options: float) -> list[LoadStep]:
    """The load steps of ``record`` with the oil volume stored in each (module docstring).

    Parameters
    ----------
    record
        A uniformly sampled cycle.
    pressure, flow
        Pump pressure [Pa] and working flow [m³/s] channels.
    min_flow_fraction
        A plateau whose mean flow is below this fraction [-] of the largest plateau flow is a
        no-flow (relief) plateau; a step must join two working plateaus.
    max_gap
        Longest transition between two plateaus [s]; longer gaps are not one step.
    min_step
        Smallest pressure change [Pa] counted as a step.
    relaxation
        Relaxation time of the gas [s]: with > 0 the steady flow ``q_ss`` runs through the
        plateaus' settled flows (:func:`~diagnostics.real.relaxation.settled_flow`), not
        their means, so the gas's slow heat exchange after the previous step does not shift
        the pump line the stored oil is counted against.
    plateau_options
        Passed to :func:`~diagnostics.real.leakage.record_plateaus`.
    """
    rate = uniform_rate(record)
    plats = record_plateaus(record, pressure=pressure, **plateau_options)
    p, q = record.channel(pressure), record.channel(flow)
    means = [(a, b, float(p[a:b].mean()), float(q[a:b].mean())) for a, b in plats]
    top = max((m[3] for m in means), default=0.0)
    if relaxation > 0:
        means = [(a, b, pm, settled_flow(q[a:b], relaxation * rate)) for a, b, pm, _ in means]
    dt = 1.0 / rate
    steps: list[LoadStep] = []
    for (_, b1, p1, q1), (a2, _, p2, q2) in itertools.pairwise(means):
        working = top > 0 and min(q1, q2) >= min_flow_fraction * top
        if not working or (a2 - b1) * dt > max_gap or abs(p2 - p1) < min_step:
            continue
        pk, qk = p[b1:a2], q[b1:a2]
        qss = q1 + (pk - p1) * (q2 - q1) / (p2 - p1)
        steps.append(LoadStep(p1, p2, float(np.sum(qss - qk)) * dt,
                              float(record.t[b1] - record.t[0])))
    return steps


def gas_volume(steps: Sequence[LoadStep], *, n: float = 1.4, p_ref: float = 150.0e5,
               theta: float | None = None, theta_ref: float = 20.0) -> float:
    """Accumulator gas volume at ``p_ref`` [m³] from the given load steps (module docstring).

    ``A = Σ sgn(Δg_k)·ΔV_k / Σ |Δg_k|`` (rises and falls both count positive), then
    ``V_gas = A·p_ref^(−1/n)``; with the oil temperature ``theta`` [°C] given, times
    ``((theta_ref + 273.15)/(theta + 273.15))^(1/n)`` (the pre-charge referred to
    ``theta_ref`` [°C]).

    Raises
    ------
    InputError
        ``n`` ≤ 0 or ``p_ref`` ≤ 0.
    MeasurementError
        No step (``field="steps"``).
    """
    if not (n > 0 and p_ref > 0):
        raise InputError(f"n and p_ref must be positive, got n={n}, p_ref={p_ref}",
                         field="n" if not n > 0 else "p_ref")
    if not steps:
        raise MeasurementError("no load step between working plateaus", field="steps")
    g = np.array([s.polytropic_term(n) for s in steps])
    v = np.array([s.volume for s in steps])
    a = float(np.sum(np.sign(g) * v) / np.sum(np.abs(g)))
    if theta is not None:
        a *= ((theta_ref + ABSOLUTE_ZERO) / (theta + ABSOLUTE_ZERO)) ** (1.0 / n)
    return a * p_ref ** (-1.0 / n)


def upper_steps(steps: Sequence[LoadStep]) -> list[LoadStep]:
    """The steps whose both plateaus lie in the upper half of the cycle's plateau pressures.

    The plateau pressures are those the steps join (``p_from`` of the first, ``p_to`` of
    each); a step is kept when the lower of its two pressures is at least the middle one
    of them (the median, the lower middle one for an even count) [Pa].
    """
    if not steps:
        return []
    levels = sorted([steps[0].p_from, *(s.p_to for s in steps)])
    middle = levels[(len(levels) - 1) // 2]
    return [s for s in steps if min(s.p_from, s.p_to) >= middle]


def gas_volumes(records: Sequence[SeriesRecord], *,
                steps: Sequence[int] | Literal["upper"] | None = "upper",
                n: float = 1.4, p_ref: float = 150.0e5, expected_steps: int | None = 4,
                temperature: str | None = "oil_temperature", theta_ref: float = 20.0,
                **step_options: Any) -> Arr:
    """Gas volume [m³] of every cycle from its upper load steps, or those numbered ``steps``.

    ``steps="upper"``: :func:`upper_steps` of each cycle (module docstring); a sequence:
    the steps of those numbers (0-based, in order); None: every step.  A cycle whose step
    count differs from ``expected_steps`` (a cycle that left the load program, e.g. the
    relief valve holding the pressure through the middle plateaus) gets NaN, as does one
    without the selected steps.  With a
    ``temperature`` channel [°C] (None: no correction), its mean over the record refers the
    gas volume to ``theta_ref`` [°C].
    """
    out = np.full(len(records), math.nan)
    for i, r in enumerate(records):
        try:
            found = step_volumes(r, **step_options)
        except MeasurementError:
            continue
        if expected_steps is not None and len(found) != expected_steps:
            continue
        if steps == "upper":
            chosen = upper_steps(found)
            if not chosen:
                continue
        else:
            chosen = found if steps is None else [found[k] for k in steps if k < len(found)]
            if steps is not None and len(chosen) != len(steps):
                continue
        theta = (float(np.mean(r.channel(temperature))) if temperature is not None
                 else None)
        out[i] = gas_volume(chosen, n=n, p_ref=p_ref, theta=theta, theta_ref=theta_ref)
    return out
