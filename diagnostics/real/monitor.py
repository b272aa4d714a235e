"""Pump leakage per stored cycle of a rig without a working/return cycle, and its shifts.

What ``POST /rigs/{rig_id}/pump-leak`` and ``hydrodiag pump-leak`` run on a rig's stored
cycles — a constant-speed pump feeding a loaded circuit through pressure plateaus, such as
the ZeMA rig (``sim/rigs/zema.yaml``), whose cycles have no diagnosis history since
``/diagnose`` needs a cylinder's strokes:

1. each cycle's settled working plateaus (:func:`~diagnostics.real.leakage.cycle_point`
   with ``stop_at_relief``: the plateaus up to its first departure to the relief valve;
   each plateau's flow taken after the accumulator gas's relaxation ``τ``,
   :func:`~diagnostics.real.relaxation.settled_flow`);
2. its leak size against a healthy reference at the cycle's own oil temperature and
   pressure, an orifice plus a laminar shunt (paper 000 eq. 6 form,
   :mod:`diagnostics.real.shunt`)::

       Δq = q_ref(θ, p) − q = K·√Δp + λ·Δp/μ(θ)·[leaking]

   ``K`` [m³/(s·Pa^½)] per cycle, and ``K·√Δp`` [m³/s], the orifice's leak at the cycle's
   plateau pressure; the healthy reference is the batch's own lower group, or cycles known
   healthy (``baseline``) when given;
3. the shifts of ``K`` over the cycles in time order
   (:func:`~diagnostics.real.leakage.change_points`, binary segmentation with a BIC
   penalty: a step is what a worn or failed part gives; a straight-line forecast on such
   data is not meaningful), each step of practical size (:func:`_shifts`).

Choices, said in the answer's ``notes`` where they apply: the cycles are taken in the order
of their clock times when every one has one (as given otherwise); the healthy slope
``dq/dp`` and the shunt ``λ`` are fitted on the cycles that pooled as many working
plateaus as any cycle of the batch (those that ran the whole load program, as ``make
real-data`` fits them); the shifts are found among the cycles that have a size (a baseline
leaves those it does not cover without one), each segment at least ``min_segment`` cycles
long.  Nothing is stored: the answer is computed from the stored cycles each time.

On the ZeMA campaign (``make real-data``) this leak size reaches Spearman 0.897 with the
pump-leakage label, 99.7 % of what the label's ties allow (docs/real-data.md).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import numpy as np
import numpy.typing as npt

from diagnostics.real.leakage import CyclePoint, change_points, cycle_point
from diagnostics.real.relaxation import MAX_RELAXATION, ZEMA_RELAXATION
from diagnostics.real.shunt import MIN_LEAK_FRACTION, HealthyBaseline, shunt_estimates
from diagnostics.timeseries import SeriesRecord
from sim.components.gear_pump import dynamic_viscosity
from sim.errors import InputError, MeasurementError
from sim.fluid import Fluid

__all__ = ["CHANNELS", "CycleLeak", "LeakMonitor", "LeakShift", "PackedCycles",
           "missing_channels", "monitor_packed", "monitor_pump_leak", "pack_cycles"]

Arr = npt.NDArray[np.float64]

#: the channels a cycle must have: pump pressure [Pa] and working flow [m³/s] (the oil
#: temperature as a channel or as the record's stated condition)
CHANNELS = ("p_pump", "q_work")


@dataclass(frozen=True)
class CycleLeak:
    """One cycle's leak.

    Attributes
    ----------
    name, series_id
        The record's name and its stored id (None for a record not read from the store).
    measured_at
        Clock time of the cycle's first sample [UTC], None when unknown.
    theta, pressure, flow
        Oil temperature [°C], pressure [Pa] and settled flow [m³/s] of its working plateaus.
    deficit
        Healthy reference flow at its θ and pressure less its flow [m³/s].
    size
        Orifice leak size ``K`` [m³/(s·Pa^½)]; NaN where a baseline has no cycle within
        the temperature window (not judged).
    leak_flow
        ``K·√Δp``, the orifice's leak at the cycle's plateau pressure [m³/s].
    leaking
        Above the leak threshold [-] (False where not judged).
    """

    name: str
    series_id: int | None
    measured_at: datetime | None
    theta: float
    pressure: float
    flow: float
    deficit: float
    size: float
    leak_flow: float
    leaking: bool


@dataclass(frozen=True)
class LeakShift:
    """A step of the leak size between two segments of cycles.

    Attributes
    ----------
    index
        Position in :attr:`LeakMonitor.cycles` of the first cycle after the step [-].
    name, measured_at
        That cycle's name and clock time (None when unknown).
    before, after
        Median ``K`` of the segment before and after the step [m³/(s·Pa^½)].
    """

    index: int
    name: str
    measured_at: datetime | None
    before: float
    after: float


@dataclass(frozen=True)
class LeakMonitor:
    """The leak of every cycle of a batch, the values found without labels, the shifts.

    Attributes
    ----------
    cycles
        One :class:`CycleLeak` per cycle, in time order (module docstring).
    reference
        ``"batch"`` (the leak beyond the batch's lower group) or ``"baseline"`` [-].
    threshold
        Deficit above which a cycle leaks [m³/s].
    slope
        Healthy ``dq/dp`` [m³/(s·Pa)].
    shunt
        ``λ`` of the laminar shunt [m³] (its flow ``λ·Δp/μ``).
    separation
        Of the batch's leak split [robust σ]; NaN against a baseline.
    relaxation
        The accumulator gas's relaxation time ``τ`` used [s].
    fitted_on
        Cycles the slope and the shunt were fitted on [-].
    shifts
        Steps of ``K`` over the cycles.
    notes
        What the estimate chose or could not do, in words.
    """

    cycles: tuple[CycleLeak, ...]
    reference: str
    threshold: float
    slope: float
    shunt: float
    separation: float
    relaxation: float
    fitted_on: int
    shifts: tuple[LeakShift, ...]
    notes: tuple[str, ...]


def _series_id(record: SeriesRecord) -> int | None:
    sid = record.metadata.get("series_id")
    return int(sid) if isinstance(sid, int) else None


def _who(record: SeriesRecord) -> str:
    sid = _series_id(record)
    return f"series {sid} ({record.name!r})" if sid is not None else f"record {record.name!r}"


def _check(rec: SeriesRecord, field: str) -> None:
    """A record without the channels the estimate reads is refused by name."""
    missing = [c for c in CHANNELS if c not in rec.channels]
    if ("oil_temperature" not in rec.channels
            and not math.isfinite(rec.condition.get("oil_temperature", math.nan))):
        missing.append("oil_temperature")
    if missing:
        raise InputError(missing_channels(_who(rec), missing), field=field)


def missing_channels(who: str, missing: Sequence[str]) -> str:
    """What a cycle without the channels the estimate reads is told (``who``: the cycle)."""
    return (f"{who} has no {', '.join(missing)} channel: the pump's leak is read from the "
            "pump pressure p_pump [Pa], the working flow q_work [m³/s] and the oil "
            "temperature (a channel or the stated condition) on the plateaus of a rig "
            "without a working/return cycle")


def _points(records: Sequence[SeriesRecord], relaxation: float, field: str
            ) -> list[CyclePoint]:
    """Each record's plateau means; a record the estimate cannot read is refused by name."""
    out = []
    for rec in records:
        _check(rec, field)
        try:
            out.append(cycle_point(rec, stop_at_relief=True, relaxation=relaxation))
        except (InputError, MeasurementError) as exc:
            raise InputError(f"{_who(rec)}: {exc.message}", field=field) from None
    return out


def monitor_pump_leak(records: Sequence[SeriesRecord], fluid: Fluid, *,
                      baseline: Sequence[SeriesRecord] | None = None,
                      shunt: float | None = None, relaxation: float = ZEMA_RELAXATION,
                      window: float = 1.0, min_segment: int = 10,
                      field: str = "series_ids",
                      baseline_field: str = "baseline_series_ids") -> LeakMonitor:
    """The leak of each cycle of ``records`` and its shifts (module docstring).

    Parameters
    ----------
    records
        The cycles (uniformly sampled; channels :data:`CHANNELS` and the oil temperature).
    fluid
        The rig's oil (its viscosity law μ(θ)).
    baseline
        Cycles known healthy (after commissioning or an overhaul) to read the batch
        against; without them the batch's lower group is its healthy reference.
    shunt
        ``λ`` [m³] as given (fitted once on a campaign that spans the oil temperatures)
        instead of fitted on the batch.
    relaxation
        The accumulator gas's relaxation time ``τ`` [s] (0: plateau means).
    window
        Half-width [°C] of the oil-temperature neighbourhood of the healthy reference.
    min_segment
        Fewest cycles on each side of a shift [-].
    field, baseline_field
        The request's names of the records and of the baseline, for errors.

    Raises
    ------
    InputError
        Fewer than 2 cycles; a cycle without the channels or without a working plateau;
        a batch of one class of cycles without a baseline (``baseline_field``); an
        argument out of range (its name).
    """
    if len(records) < 2:
        raise InputError("the leak is read against other cycles: give at least 2",
                         field=field)
    if not (math.isfinite(relaxation) and 0.0 <= relaxation <= MAX_RELAXATION):
        raise InputError(f"must be 0 to {MAX_RELAXATION:g} s", field="relaxation")
    if not (math.isfinite(window) and window > 0.0):
        raise InputError("must be a positive temperature difference [°C]", field="window")
    if min_segment < 2:
        raise InputError("a segment holds at least 2 cycles", field="min_segment")
    if shunt is not None and not (math.isfinite(shunt) and shunt >= 0.0):
        raise InputError("must be a non-negative volume [m³]", field="shunt")
    notes: list[str] = []
    starts = [r.measured_at for r in records]
    if all(s is not None for s in starts):
        order = sorted(range(len(records)), key=lambda i: (starts[i], i))
        shared = len(starts) - len(set(starts))
        if shared:  # an import whose records each restart at t = 0 gives them one start
            notes.append(f"{shared} cycle(s) share a clock time with another: among equal "
                         "times the cycles are taken in the order given")
    else:
        order = list(range(len(records)))
        notes.append("not every cycle has a clock time: the cycles are taken in the order "
                     "given, and the shifts are read in that order")
    recs = [records[i] for i in order]
    pts = _points(recs, relaxation, field)
    theta = np.array([p.theta for p in pts])
    mu = np.asarray(dynamic_viscosity(fluid, theta), dtype=np.float64)
    counts = np.array([p.plateaus for p in pts])
    full = counts == counts.max()
    healthy = None
    if baseline is not None:
        base = list(baseline)
        healthy = HealthyBaseline(base, _points(base, relaxation, baseline_field))
    try:
        est = shunt_estimates(recs, pts, mu, fit_on=full, window=window, shunt=shunt,
                              baseline=healthy)
    except InputError as exc:
        raise InputError(exc.message, field=baseline_field if exc.field == "baseline"
                         else field) from None
    notes += list(est.notes)
    if shunt is None:
        notes.append(f"the healthy slope and the shunt λ are fitted on the {int(full.sum())} "
                     f"of {full.size} cycles that pooled {int(counts.max())} working "
                     "plateau(s), as many as any cycle of the batch")
    p = np.array([c.pressure for c in pts])
    cycles = tuple(
        CycleLeak(r.name, _series_id(r), r.measured_at, pt.theta, pt.pressure, pt.flow,
                  float(d), float(k), float(k * math.sqrt(pr)), bool(lk))
        for r, pt, d, k, pr, lk in zip(recs, pts, est.deficit, est.size, p, est.leaking,
                                       strict=True))
    shifts, merged = _shifts(cycles, np.asarray(est.size, dtype=np.float64), min_segment)
    if merged:
        notes.append(f"{merged} step(s) of the leak size below the practical size "
                     f"({100 * MIN_LEAK_FRACTION:g} % of the median flow at the median "
                     "plateau pressure) merged into their neighbours")
    return LeakMonitor(cycles, est.reference, est.threshold, est.slope, est.shunt,
                       est.separation, relaxation, int(full.sum()), shifts, tuple(notes))


def _shifts(cycles: tuple[CycleLeak, ...], size: Arr, min_segment: int
            ) -> tuple[tuple[LeakShift, ...], int]:
    """The steps of the size among the cycles that have one (module docstring), and how
    many steps below the practical size were merged away.

    A step is kept when the leak it adds or removes at the batch's median plateau pressure,
    ``|ΔK|·√p``, is at least :data:`~diagnostics.real.shunt.MIN_LEAK_FRACTION` of the
    median flow — the practical size below which the leak split itself calls a difference
    a flow meter's scatter: on 500 ZeMA cycles the BIC finds 15 steps, 8 of them within a
    leak class (the oil temperature's drift, 0.2-0.4 % of the flow), and the 7 kept are the
    class switches.  The smallest step below that size is merged away first and the
    medians of the merged segments taken again, until every step left is of practical size.
    """
    have = np.flatnonzero(np.isfinite(size))
    cps = change_points(size[have], min_size=min_segment)
    if not cps:
        return (), 0
    flow = float(np.median([c.flow for c in cycles]))
    root = math.sqrt(float(np.median([c.pressure for c in cycles])))
    practical = MIN_LEAK_FRACTION * flow
    found = len(cps)
    vals = size[have]

    def medians(cuts: list[int]) -> list[float]:
        edges = [0, *cuts, vals.size]
        return [float(np.median(vals[a:b])) for a, b in itertools.pairwise(edges)]

    while cps:
        med = medians(cps)
        steps = [abs(b - a) * root for a, b in itertools.pairwise(med)]
        j = int(np.argmin(steps))
        if steps[j] >= practical:
            break
        del cps[j]
    med = medians(cps)
    out = []
    for j, c in enumerate(cps):
        i = int(have[c])
        out.append(LeakShift(i, cycles[i].name, cycles[i].measured_at, med[j], med[j + 1]))
    return tuple(out), found - len(cps)


@dataclass(frozen=True)
class PackedCycles:
    """Cycles as a few flat arrays: what is sent to another process.  A list of records,
    pickled object by object with every channel and note, held the sending process's
    interpreter lock 82 ms for the 2,205 ZeMA cycles (``/health`` waits on that lock);
    these arrays take a few ms.

    Attributes
    ----------
    names, series_ids, starts
        Each cycle's name, stored id (None when not stored) and clock time at ``t = 0``.
    offsets
        Cycle ``k``'s samples are ``offsets[k]:offsets[k + 1]`` of the arrays [-].
    t, p_pump, q_work, theta
        Times [s], pump pressure [Pa], working flow [m³/s] and oil temperature [°C] of
        every sample, cycle after cycle; ``theta`` NaN where a cycle has no such channel.
    stated_theta
        Each cycle's stated oil temperature [°C] (NaN when none).
    """

    names: tuple[str, ...]
    series_ids: tuple[int | None, ...]
    starts: tuple[datetime | None, ...]
    offsets: npt.NDArray[np.int64]
    t: Arr
    p_pump: Arr
    q_work: Arr
    theta: Arr
    stated_theta: Arr

    def records(self) -> list[SeriesRecord]:
        """The cycles as records again (the channels the estimate reads)."""
        out = []
        for k, name in enumerate(self.names):
            a, b = int(self.offsets[k]), int(self.offsets[k + 1])
            channels = {"p_pump": self.p_pump[a:b], "q_work": self.q_work[a:b]}
            units = {"p_pump": "Pa", "q_work": "m^3/s"}
            if not np.isnan(self.theta[a:b]).all():
                channels["oil_temperature"] = self.theta[a:b]
                units["oil_temperature"] = "degC"
            stated = float(self.stated_theta[k])
            sid = self.series_ids[k]
            out.append(SeriesRecord(
                name, self.t[a:b], channels, units,
                condition={} if math.isnan(stated) else {"oil_temperature": stated},
                metadata={} if sid is None else {"series_id": sid},
                started_at=self.starts[k]))
        return out


def pack_cycles(records: Sequence[SeriesRecord], *, field: str = "series_ids"
                ) -> PackedCycles:
    """``records`` as :class:`PackedCycles` (a record without the channels the estimate
    reads is refused by name, ``field``)."""
    for rec in records:
        _check(rec, field)
    sizes = [len(r) for r in records]
    return PackedCycles(
        tuple(r.name for r in records), tuple(_series_id(r) for r in records),
        tuple(r.started_at for r in records),
        np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
        np.concatenate([r.t for r in records]),
        np.concatenate([r.channels["p_pump"] for r in records]),
        np.concatenate([r.channels["q_work"] for r in records]),
        np.concatenate([r.channels.get("oil_temperature", np.full(len(r), math.nan))
                        for r in records]),
        np.array([r.condition.get("oil_temperature", math.nan) for r in records], dtype=float))


def monitor_packed(cycles: PackedCycles, fluid: Fluid, *,
                   baseline: PackedCycles | None = None, **options: Any) -> LeakMonitor:
    """:func:`monitor_pump_leak` of packed cycles (on another process: the service)."""
    return monitor_pump_leak(cycles.records(), fluid,
                             baseline=None if baseline is None else baseline.records(),
                             **options)
