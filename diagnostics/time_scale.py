"""Whether a measured cycle's clock can be right: its piston speed against what the pump can drive.

A record's time comes from its file's time column or from the sample rate its importer
states; a rate stated wrong (a 1 kHz logger imported as 100 Hz, a 100 Hz one as 1 Hz) stores
every sample at the wrong time and nothing in the file itself says so.  On a rig with a
pump and a cylinder the physics does: the piston cannot move faster than the pump's
geometric delivery fills its smaller chamber,

    |ẋ| ≤ Qp / A_min,   Qp = ω·Vp   (paper 002 eq. 2; the chamber volumes V0 + A·x of
                                   eqs. 33-34 grow no faster than the flow into them),

with no accumulator in the circuit to add flow (ω + Δω where the rig carries a
speed-reading offset Δω, paper 000 §5: :meth:`~diagnostics.consistency.RigLimits.delivery`).
A record whose piston crosses the middle 80 % of its travel faster than 1.5× that bound
runs on a clock too fast (the rate stated too high); one that crosses it more than 30×
slower than the bound is possible (a throttled or nearly stalled piston) but is also what a
rate stated 30× or more too low looks like: a note says so and names the factor.  A record
with a speed channel ``v`` beside its position is also judged against itself: ``x`` must
cross its travel at the speed ``v`` integrated over the record's times says, whatever the
rig.  Only records whose position shows a full crossing of at least a fifth of the stroke
are judged.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from diagnostics.consistency import (  # a crossing slower than the bound ÷ SLOW_FACTOR: noted
    SLOW_FACTOR,
    RigLimits,
)
from diagnostics.timeseries import SeriesRecord

__all__ = ["FAST_FACTOR", "MIN_STROKE_SAMPLES", "MIN_TRAVEL", "SLOW_FACTOR", "coarse_notes",
           "crossing_speed", "time_scale_notes"]

Arr = npt.NDArray[np.float64]

#: a crossing faster than this × the pump's bound is impossible: the clock runs fast [-]
FAST_FACTOR = 1.5
#: least travel a judged crossing spans, as a fraction of the stroke [-]
MIN_TRAVEL = 0.2
#: fewest samples that place a stroke (its start, its speed, its end) [-]
MIN_STROKE_SAMPLES = 20


def crossing_speed(t: Arr, x: Arr, min_span: float = 0.0) -> float | None:
    """Mean speed of the fastest crossing of the middle 80 % of ``x``'s range [m/s]
    (from the last sample at or beyond one 10 % level to the first at or beyond the
    other 90 % level, either way); None without such a crossing or with a range (1-99th
    percentile) not above ``min_span`` [m]."""
    ok = np.isfinite(x)
    t, x = t[ok], x[ok]
    if x.size < 3:
        return None
    lo_x, hi_x = np.percentile(x, [1.0, 99.0])
    span = float(hi_x - lo_x)
    if not span > max(min_span, 0.0):
        return None
    lo, hi = lo_x + 0.1 * span, lo_x + 0.9 * span
    best = math.inf
    last_lo = last_hi = None
    for ti, xi in zip(t.tolist(), x.tolist(), strict=True):
        if xi <= lo:
            if last_hi is not None:
                best = min(best, ti - last_hi)
                last_hi = None
            last_lo = ti
        elif xi >= hi:
            if last_lo is not None:
                best = min(best, ti - last_lo)
                last_lo = None
            last_hi = ti
    if not math.isfinite(best) or best <= 0:
        return None
    return 0.8 * span / best


def time_scale_notes(records: Sequence[SeriesRecord], limits: RigLimits | None) -> list[str]:
    """Notes on the records whose piston crosses its travel faster than the pump can drive
    it or ≥ :data:`SLOW_FACTOR` × slower (module docstring), by the position ``x``, and
    those whose ``x`` moves more than :data:`FAST_FACTOR` × faster or slower than their
    speed channel ``v`` integrated says (a speed reading alone does not depend on the
    clock).  ``limits``: the rig's (:func:`diagnostics.observations.rig_limits`: the pump's
    delivery with any speed offset, the chambers' areas, the stroke).  Nothing without
    them, a position or a full crossing."""
    if limits is None or limits.stroke is None:
        return []
    fast: list[tuple[str, float]] = []
    slow: list[tuple[str, float]] = []
    apart: list[tuple[str, float]] = []
    least = MIN_TRAVEL * limits.stroke
    for r in records:
        if "x" not in r.channels:
            continue  # a speed reading alone is a speed whatever the clock says
        speed = crossing_speed(r.t, r.channels["x"], least)
        if speed is None:
            continue
        ratio = speed / limits.max_piston_speed(r.condition.get("pump_speed"))
        if ratio > FAST_FACTOR:
            fast.append((r.name, ratio))
        elif ratio < 1.0 / SLOW_FACTOR:
            slow.append((r.name, ratio))
        if "v" in r.channels and r.t.size > 2:  # the position against the speed reading
            v = np.nan_to_num(r.channels["v"])
            travel = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(r.t))])
            read = crossing_speed(r.t, travel, least)
            if read is not None and not 1.0 / FAST_FACTOR <= speed / read <= FAST_FACTOR:
                apart.append((r.name, speed / read))
    notes = []
    if fast:
        notes.append(
            f"record(s) {_shown(fast)}: the piston crosses its travel {_factor(fast)} faster "
            "than the pump's delivery can drive it (ω·Vp over the smaller chamber area): its "
            "times are too short by at least about that factor — a sample rate stated too "
            "high, or a time column in the wrong unit?")
    if slow:
        notes.append(
            f"record(s) {_shown(slow)}: the piston crosses its travel {_factor(slow, 1)} "
            "slower than the pump's delivery would drive it: if the cylinder was neither "
            "throttled nor near stall, its times are too long by up to about that factor — "
            "a sample rate stated too low, or a time column in the wrong unit?")
    if apart:
        notes.append(
            f"record(s) {_shown(apart)}: the position x moves at {_factor(apart)} the speed "
            "its own speed channel v reads: the times are off by that factor (a wrong "
            "sample rate or time unit) or x or v is in the wrong unit")
    return notes


def _shown(items: list[tuple[str, float]]) -> str:
    return ", ".join(repr(n) for n, _ in items[:3]) + (" …" if len(items) > 3 else "")


def _factor(items: list[tuple[str, float]], power: int = 0) -> str:
    """The factor by which the records' crossing differs from the bound, e.g. '12×' or
    '12-40×' (``power`` 1: the inverse ratios)."""
    f = sorted(r if power == 0 else 1.0 / r for _, r in items)
    lo, hi = f[0], f[-1]
    return f"{lo:.3g}×" if hi < 1.05 * lo else f"{lo:.3g}-{hi:.3g}×"


def coarse_notes(records: Sequence[SeriesRecord], limits: RigLimits | None) -> list[str]:
    """Notes on the records too short or too coarsely sampled to hold a stroke: fewer than
    :data:`MIN_STROKE_SAMPLES` samples, or samples further apart than the fastest stroke
    the pump can drive (stroke over :meth:`~RigLimits.max_piston_speed`) divided by that
    number.  A 5-sample record and a 5 Hz one were stored without a word and read back as
    a stalled or crept stroke, which an engineer takes for a mechanical fault (a
    discrepancy pass).  Nothing without the rig's limits or stroke."""
    if limits is None or limits.stroke is None:
        return []
    notes = []
    for r in records:
        fastest = limits.stroke / limits.max_piston_speed(r.condition.get("pump_speed"))
        if len(r) < MIN_STROKE_SAMPLES:
            notes.append(f"record {r.name!r} holds {len(r)} sample(s), too few to hold a "
                         f"stroke (≥ {MIN_STROKE_SAMPLES}): read as a record it shows no "
                         "stroke, or a stalled one, which is no finding")
            continue
        step = float(np.median(np.diff(r.t)))
        if step > fastest / MIN_STROKE_SAMPLES:
            notes.append(
                f"record {r.name!r} is sampled every {step * 1e3:.4g} ms ({1.0 / step:.3g} "
                f"Hz): a stroke at the pump's full delivery lasts {fastest:.3g} s, "
                f"{fastest / step:.3g} samples, too few to place its start, speed and end; a "
                "stroke read from it (stalled, crept) is no finding: log at ≥ "
                f"{math.ceil(MIN_STROKE_SAMPLES / fastest)} Hz")
    return notes
