"""The pump's leak per stored cycle of a rig without a cylinder (``POST /rigs/{rig_id}/pump-leak``,
``hydrodiag pump-leak``): :func:`diagnostics.real.monitor.monitor_pump_leak` on stored series.

Nothing is stored: the answer is computed from the stored cycles on each call (~0.3 ms of
CPU a cycle; the 2,205 ZeMA cycles in a few seconds with their reading from the store).

In the service the estimate runs on the sweeps' executor (a process, or a Dask worker),
not in the request's thread: its thousands of small numpy calls each let go of the
interpreter lock and take it back at once, and a thread waiting for the lock only asks
for it when nobody has taken it for 5 ms — beside the estimate of the 2,205 ZeMA cycles
in a thread, a thread that slept 1 ms woke up to 139-165 ms late (p99 24-42 ms, two
measurements), and beside it on a process at most 8.6 ms (``make job-stall``), where
``/health`` must answer within 20 ms.  The cycles are sent packed in a few arrays
(:class:`~diagnostics.real.monitor.PackedCycles`): pickled as records they held this
process's lock 82 ms.
"""

from __future__ import annotations

import functools
import itertools
import math
import statistics
from concurrent.futures import Executor
from dataclasses import dataclass

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.db.models import MeasuredSeries
from app.schemas.pump_leak import (
    MAX_CYCLES,
    CycleLeakPublic,
    LeakShiftPublic,
    PumpLeakRequest,
    PumpLeakResponse,
)
from app.services.rig_cache import RigCache
from app.services.series import stored_records
from diagnostics.real.monitor import (
    CHANNELS,
    LeakMonitor,
    missing_channels,
    monitor_packed,
    pack_cycles,
)
from sim.errors import InputError

__all__ = ["LeakSegment", "pump_leak", "response_of", "segments"]


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _batch_ids(session: Session, rig_id: int, request: PumpLeakRequest
               ) -> tuple[list[int], str | None]:
    """The ids of the cycles to read, in order of import: those given, or the rig's latest
    ``last`` (:data:`MAX_CYCLES` without it) stored cycles but the baseline's; and a note
    when stored cycles were left out."""
    base = set(request.baseline_series_ids or ())
    if request.series_ids is not None:
        if request.last is not None:
            raise InputError("give series_ids or last, not both: last picks the rig's latest "
                             "stored cycles when series_ids is null", field="last")
        both = sorted(base.intersection(request.series_ids))
        if both:
            raise InputError(f"series {', '.join(map(str, both[:10]))} "
                             f"{'is' if len(both) == 1 else 'are'} in both the batch and "
                             "the baseline: a cycle is not its own healthy reference",
                             field="baseline_series_ids")
        return list(request.series_ids), None
    mine = [MeasuredSeries.rig_id == rig_id]
    if base:
        mine.append(MeasuredSeries.id.not_in(base))
    total = session.scalar(select(func.count()).select_from(MeasuredSeries).where(*mine)) or 0
    besides = " besides the baseline" if base else ""
    if total < 2:
        raise InputError(f"rig {rig_id} has {total} stored cycle(s) to read{besides}: import "
                         "its cycles first (POST /rigs/{rig_id}/series, hydrodiag import)",
                         field="series_ids")
    wanted = request.last or MAX_CYCLES
    ids = sorted(session.scalars(
        select(MeasuredSeries.id).where(*mine)
        .order_by(MeasuredSeries.measured_at.desc().nulls_last(), MeasuredSeries.id.desc())
        .limit(wanted)))
    if len(ids) == total:
        return ids, None
    return ids, (f"read the latest {len(ids)} of the rig's {total} stored cycles{besides} (by "
                 "clock time, then order of import"
                 + ("" if request.last else f": at most {MAX_CYCLES} a request")
                 + "); name others in series_ids")


def _check_channels(session: Session, rig_id: int, ids: list[int], field: str) -> None:
    """Refuse, before their samples are read, stored series of the rig without the pump
    pressure and the working flow (a cylinder rig's cycles: thousands of them at 1 kHz were
    read whole to be refused one by one); those of another rig or none are refused as such
    after (:func:`~app.services.series.stored_records`)."""
    for sid, units in session.execute(select(MeasuredSeries.id, MeasuredSeries.units)
                                      .where(MeasuredSeries.id.in_(ids),
                                             MeasuredSeries.rig_id == rig_id)
                                      .order_by(MeasuredSeries.id)):
        missing = [c for c in CHANNELS if c not in units]
        if missing:
            raise InputError(f"{missing_channels(f'series {sid}', missing)} (its channels: "
                             f"{', '.join(sorted(units)) or 'none'})", field=field)


def pump_leak(session: Session, rigs: RigCache, rig_id: int, request: PumpLeakRequest, *,
              executor: Executor | None = None) -> PumpLeakResponse:
    """The leak of each stored cycle of rig ``rig_id`` (module docstring), computed on
    ``executor`` (in this thread without one: the command line).

    Raises
    ------
    NotFoundError
        No such rig, or a series id names no stored series.
    InputError
        A series of another rig, in both lists, without the channels or plateaus the
        estimate reads; a batch of one class of cycles without a baseline
        (``baseline_series_ids``); too many or too few cycles.
    """
    resolved = rigs.get(session, rig_id)
    ids, left_out = _batch_ids(session, rig_id, request)
    _check_channels(session, rig_id, ids, "series_ids")
    if request.baseline_series_ids is not None:
        _check_channels(session, rig_id, request.baseline_series_ids, "baseline_series_ids")
    records = pack_cycles(stored_records(session, rig_id, ids, field="series_ids"))
    baseline = (None if request.baseline_series_ids is None else pack_cycles(
        stored_records(session, rig_id, request.baseline_series_ids,
                       field="baseline_series_ids"), field="baseline_series_ids"))
    task = functools.partial(monitor_packed, records, resolved.rig.fluid,
                             baseline=baseline, shunt=request.shunt,
                             relaxation=request.relaxation, window=request.window,
                             min_segment=request.min_segment)
    found = task() if executor is None else executor.submit(task).result()
    answer = response_of(rig_id, resolved.version, found)
    if left_out is not None:
        answer.notes.insert(0, left_out)
    return answer


def response_of(rig_id: int, version: int, found: LeakMonitor) -> PumpLeakResponse:
    """The answer of :func:`pump_leak` from the estimate."""
    cycles = [CycleLeakPublic(series_id=c.series_id, name=c.name, measured_at=c.measured_at,
                              oil_temperature=c.theta, pressure=c.pressure, flow=c.flow,
                              deficit=c.deficit, size=_finite(c.size),
                              leak_flow=_finite(c.leak_flow), leaking=c.leaking)
              for c in found.cycles]
    shifts = [LeakShiftPublic(index=s.index, series_id=found.cycles[s.index].series_id,
                              name=s.name, measured_at=s.measured_at,
                              size_before=s.before, size_after=s.after)
              for s in found.shifts]
    return PumpLeakResponse(
        rig_id=rig_id, rig_version=version, reference=found.reference,
        leaking=sum(c.leaking for c in found.cycles), threshold=found.threshold,
        slope=found.slope, shunt=found.shunt, separation=_finite(found.separation),
        relaxation=found.relaxation, fitted_on=found.fitted_on, cycles=cycles,
        shifts=shifts, notes=list(found.notes))


@dataclass(frozen=True)
class LeakSegment:
    """The cycles between two steps of the leak (what the CLI's and the console's tables
    and the console's chart show).

    Attributes
    ----------
    start, stop
        Positions of its first cycle and one past its last in the answer's cycles [-].
    first, last
        Its first and last cycle.
    leaking
        Its cycles above the leak threshold [-].
    leak_flow, size
        Medians of ``K·√Δp`` [m³/s] and ``K`` [m³/(s·Pa^½)] over its judged cycles (None
        when none is judged).
    theta
        Lowest and highest oil temperature of its cycles [°C].
    """

    start: int
    stop: int
    first: CycleLeakPublic
    last: CycleLeakPublic
    leaking: int
    leak_flow: float | None
    size: float | None
    theta: tuple[float, float]

    @property
    def n(self) -> int:
        """Its number of cycles [-]."""
        return self.stop - self.start


def segments(answer: PumpLeakResponse) -> list[LeakSegment]:
    """The segments of ``answer``'s cycles between its steps, in time order."""
    edges = [0, *(s.index for s in answer.shifts), len(answer.cycles)]
    out = []
    for lo, hi in itertools.pairwise(edges):
        seg = answer.cycles[lo:hi]
        flows = [c.leak_flow for c in seg if c.leak_flow is not None]
        sizes = [c.size for c in seg if c.size is not None]
        theta = [c.oil_temperature for c in seg]
        out.append(LeakSegment(lo, hi, seg[0], seg[-1], sum(c.leaking for c in seg),
                               statistics.median(flows) if flows else None,
                               statistics.median(sizes) if sizes else None,
                               (min(theta), max(theta))))
    return out
