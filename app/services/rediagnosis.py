"""Diagnose a rig's stored records again against its latest version.

Used by ``POST /rigs/{rig_id}/rediagnose`` (a job) and ``hydrodiag rigs rediagnose``.  After
commissioning or a rebuild (a new version whose parameters differ) the trends leave out
every estimate made against an older document, and posting the old records again stored a
second diagnosis per record, so the history showed them twice (a maintenance planner's
pass).  Here each current diagnosis of the chosen older versions is diagnosed again from
its stored records — a joint visit from all of them, jointly — against the latest
version; the new diagnosis is kept with the same records and the old one is marked
``superseded_by`` the new one (revision 0014): listings and trends read the current
diagnoses, and ``GET /diagnoses/{id}`` still reads the old one with the id that replaced
it.

The work is idempotent: a diagnosis already superseded is not taken again, each chunk of
results is stored in its own transaction as it comes back, and a cancelled or interrupted
job leaves what it stored; running again takes the rest.  A group whose records the latest
version cannot take (no operating point, a reading it contradicts) is reported with its
message and its old diagnosis stays current.

The diagnoses run where sweeps run (:mod:`app.services.executors`: the service's process
pool or a Dask cluster), so the server process keeps its event loop; the command line runs
them in its own process.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor, Future
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import func, select, update
from sqlalchemy.orm import Session, selectinload

from app.db.engine import SessionFactory
from app.db.models import Diagnosis, Measurement, RigVersion
from app.schemas.diagnose import MeasurementIn
from app.services.common import current_diagnoses
from app.services.diagnosis import GroupResult, compute_group
from app.services.history import estimate_row
from app.services.measurements import to_record
from app.services.rig_cache import ResolvedRig, RigCache
from app.services.trends import comparable_versions
from diagnostics.batch import as_done
from diagnostics.measurement import MeasurementRecord
from sim.errors import HydrodiagError, InputError
from sim.rigs import Rig
from sim.rigs.process_cache import rig_of_document

__all__ = ["MAX_DIAGNOSES", "RediagnosisPlan", "StaleDiagnosis", "plan_rediagnosis",
           "rediagnose_chunk", "run_rediagnosis"]

#: Most diagnoses one re-diagnosis takes [-] (at ~10 ms each, ~4 minutes on two cores, and
#: their records held in memory, ~2 kB each); a longer history is taken the oldest first,
#: and the answer says how many remain for the next run.
MAX_DIAGNOSES = 50_000
#: Diagnoses per task sent to the executor, stored in one transaction [-].
CHUNK = 25

ProgressFn = Callable[[float, str], None]


@dataclass(frozen=True, slots=True)
class StaleDiagnosis:
    """One current diagnosis of an older version and the records it was made from.

    ``records``: each record as the history keeps it and its time, in the order of their
    ids (a joint visit's result lists per-record values in that order); ``kept_with``: the
    index of the record the result is kept with.
    """

    diagnosis_id: int
    version: int
    component: str | None
    measurement_ids: tuple[int, ...]
    records: tuple[tuple[Mapping[str, Any], datetime], ...]
    kept_with: int


@dataclass(frozen=True, slots=True)
class RediagnosisPlan:
    """What a re-diagnosis takes: the latest version and the diagnoses to do again."""

    resolved: ResolvedRig
    versions: tuple[int, ...]
    stale: tuple[StaleDiagnosis, ...]
    #: diagnoses of those versions beyond this run's :data:`MAX_DIAGNOSES`, for the next
    remaining: int = 0


def _versions_present(session: Session, rig_id: int) -> set[int]:
    rows = session.scalars(
        select(RigVersion.version).distinct()
        .join(Diagnosis, Diagnosis.rig_version_id == RigVersion.id)
        .where(RigVersion.rig_id == rig_id, current_diagnoses()))
    return set(rows)


def _chosen(session: Session, resolved: ResolvedRig, versions: Sequence[int] | None
            ) -> tuple[int, ...]:
    present = _versions_present(session, resolved.rig_id) - {resolved.version}
    if versions is None:  # the versions the trends leave out: their parameters differ
        comparable = comparable_versions(session, resolved, present)
        return tuple(sorted(v for v in present if not comparable[v]))
    for i, v in enumerate(versions):
        if v == resolved.version:
            raise InputError(f"version {v} is the latest: its diagnoses are current",
                             field=f"versions[{i}]")
        if v > resolved.version or v < 1:
            raise InputError(f"rig {resolved.rig_id} has versions 1 to {resolved.version}",
                             field=f"versions[{i}]")
    return tuple(sorted(set(versions) & present))


def plan_rediagnosis(session: Session, rigs: RigCache, rig_id: int,
                     versions: Sequence[int] | None = None,
                     max_diagnoses: int = MAX_DIAGNOSES) -> RediagnosisPlan:
    """Choose the diagnoses of rig ``rig_id`` to do again against its latest version.

    Parameters
    ----------
    versions
        The older versions whose current diagnoses are done again; default: every older
        version whose parameters or fluid differ from the latest's (those the trends leave
        out; a version that changed only the title needs nothing).

    Raises
    ------
    NotFoundError
        Unknown rig.
    InputError
        A version that is the latest or does not exist; a rig without a cylinder cycle.
    """
    resolved = rigs.get(session, rig_id, None, rig_field="rig_id")
    try:
        resolved.rig.require_cycle("a diagnosis")
    except InputError as exc:  # a CircuitError: no cylinder cycle to diagnose
        raise type(exc)(exc.message, field="rig_id") from None
    chosen = _chosen(session, resolved, versions)
    if not chosen:
        return RediagnosisPlan(resolved, (), ())
    where = (RigVersion.rig_id == rig_id, RigVersion.version.in_(chosen),
             current_diagnoses())
    total = session.scalar(select(func.count()).select_from(Diagnosis).join(
        RigVersion, Diagnosis.rig_version_id == RigVersion.id).where(*where)) or 0
    rows = session.scalars(
        select(Diagnosis)
        .join(RigVersion, Diagnosis.rig_version_id == RigVersion.id).where(*where)
        .options(selectinload(Diagnosis.records), selectinload(Diagnosis.rig_version)
                 .load_only(RigVersion.version))
        .order_by(Diagnosis.id).limit(max_diagnoses)).all()
    stale = []
    for d in rows:
        records = d.records or [d.measurement]
        ids = tuple(m.id for m in records)
        stale.append(StaleDiagnosis(
            d.id, d.rig_version.version, d.component, ids,
            tuple((m.record, m.measured_at) for m in records),
            ids.index(d.measurement_id) if d.measurement_id in ids else 0))
    return RediagnosisPlan(resolved, chosen, tuple(stale), int(total) - len(stale))


def _records(stale: StaleDiagnosis, rig_id: int, rig_name: str) -> list[MeasurementRecord]:
    """The diagnostics records of a stored group (its stored rig version left aside: the
    group is diagnosed against the latest)."""
    out = []
    for i, (record, measured_at) in enumerate(stale.records):
        document = {k: v for k, v in record.items() if k not in ("rig_version", "measured_at")}
        data = MeasurementIn.model_validate(document | {"rig_id": rig_id})
        out.append(to_record(data, path=f"records[{i}]", rig_name=rig_name,
                             measured_at=measured_at))
    return out


def rediagnose_chunk(document: Mapping[str, Any], version: int,
                     groups: Sequence[Sequence[MeasurementRecord]]
                     ) -> list[GroupResult | str]:
    """Diagnose each group of records jointly on the rig of ``document`` (what a worker
    runs); a group the rig cannot take gives its message instead of a result."""
    return _computed(rig_of_document(document), version, groups)


def _computed(rig: Rig, version: int, groups: Sequence[Sequence[MeasurementRecord]]
              ) -> list[GroupResult | str]:
    out: list[GroupResult | str] = []
    for records in groups:
        try:
            out.append(compute_group(rig, records, version))
        except HydrodiagError as exc:
            out.append(f"{exc.message}" + (f" ({exc.field})" if exc.field else ""))
    return out


def _store(session: Session, plan: RediagnosisPlan, stale: StaleDiagnosis,
           computed: GroupResult) -> int | None:
    """Add the new diagnosis of ``stale`` and mark the old one superseded by it (no
    commit); ``None`` when the old one is no longer current (another run took it, or its
    records were deleted)."""
    current = session.scalar(select(Diagnosis.id).where(
        Diagnosis.id == stale.diagnosis_id, current_diagnoses()))
    if current is None:
        return None
    measurements = {m.id: m for m in session.scalars(
        select(Measurement).where(Measurement.id.in_(stale.measurement_ids)))}
    if len(measurements) != len(stale.measurement_ids):
        return None
    result = computed.result | {"record_index": stale.kept_with,
                                "rediagnosis_of": stale.diagnosis_id}
    new = Diagnosis(
        measurement=measurements[stale.measurement_ids[stale.kept_with]],
        records=[measurements[i] for i in stale.measurement_ids],
        rig_version_id=plan.resolved.version_id, component=computed.component,
        probability=computed.probability, result=result,
        estimates=[estimate_row(e.history(), result) for e in computed.estimates])
    session.add(new)
    session.flush()
    marked = session.execute(
        update(Diagnosis).where(Diagnosis.id == stale.diagnosis_id,
                                current_diagnoses())
        .values(superseded_by=new.id).execution_options(synchronize_session=False))
    if getattr(marked, "rowcount", 1) != 1:  # taken meanwhile by another run
        session.delete(new)
        session.flush()
        return None
    return new.id


def _save(sessions: SessionFactory, plan: RediagnosisPlan,
          chunk: Sequence[StaleDiagnosis], computed: Sequence[GroupResult | str],
          tally: dict[str, Any]) -> None:
    """Store one chunk's results in one transaction and count them in ``tally``."""
    replaced: list[dict[str, Any]] = []
    errors: list[dict[str, Any]] = []
    with sessions() as session:
        try:
            for stale, outcome in zip(chunk, computed, strict=True):
                if isinstance(outcome, str):
                    errors.append({"diagnosis_id": stale.diagnosis_id, "message": outcome})
                    continue
                new_id = _store(session, plan, stale, outcome)
                if new_id is None:
                    tally["skipped"] += 1
                    continue
                replaced.append({"diagnosis_id": stale.diagnosis_id, "by": new_id,
                                 "version": stale.version, "before": stale.component,
                                 "after": outcome.component})
            session.commit()
        except Exception as exc:  # a record deleted meanwhile, a lost connection
            session.rollback()
            message = f"not stored: {type(exc).__name__}; run the re-diagnosis again"
            errors = [{"diagnosis_id": s.diagnosis_id, "message": message} for s in chunk]
            replaced = []
    tally["replaced"].extend(replaced)
    tally["errors"].extend(errors)


def run_rediagnosis(plan: RediagnosisPlan, sessions: SessionFactory,
                    executor: Executor | None = None,
                    progress: ProgressFn | None = None,
                    waiting: Callable[[], None] | None = None) -> dict[str, Any]:
    """Diagnose every group of ``plan`` again and store the results chunk by chunk.

    Parameters
    ----------
    plan
        From :func:`plan_rediagnosis`.
    sessions
        The store's session factory (each chunk is stored in its own transaction).
    executor
        Where the diagnoses run (a process pool, a Dask client's executor); ``None``: in
        this process.
    progress
        Called with the fraction done [1] and a note after each chunk; when it raises (a
        cancelled job) the chunks not started are cancelled and the exception goes on.
    waiting
        With an executor, called every second while no chunk completes, and the same when
        it raises (:func:`diagnostics.batch.as_done`).

    Returns
    -------
    dict
        ``rig_id``, ``rig_version`` (the latest, diagnosed against), ``versions`` (those
        done again), ``n_diagnoses``, ``rediagnosed``, ``changed`` (the named fault
        differs), ``skipped`` (taken meanwhile), ``remaining`` (beyond this run's
        :data:`MAX_DIAGNOSES`: run again), ``replaced`` (old id, new id, before, after),
        ``errors`` (old id, message: left current); JSON-ready.
    """
    resolved = plan.resolved
    tally: dict[str, Any] = {"replaced": [], "errors": [], "skipped": 0}
    total = len(plan.stale)
    chunks: list[tuple[list[StaleDiagnosis], list[list[MeasurementRecord]]]] = []
    for start in range(0, total, CHUNK):
        chunk, groups = [], []
        for stale in plan.stale[start:start + CHUNK]:
            try:
                groups.append(_records(stale, resolved.rig_id, resolved.name))
                chunk.append(stale)
            except (HydrodiagError, ValueError) as exc:  # a record the schema refuses now
                tally["errors"].append({"diagnosis_id": stale.diagnosis_id,
                                        "message": f"its stored records no longer read: {exc}"})
        if chunk:
            chunks.append((chunk, groups))
    done = total - sum(len(c) for c, _ in chunks)

    def report(n: int) -> None:
        if progress is not None:
            progress(n / total if total else 1.0, f"diagnosis {n} of {total}")

    if executor is None:
        for chunk, groups in chunks:
            _save(sessions, plan, chunk, _computed(resolved.rig, resolved.version, groups),
                  tally)
            done += len(chunk)
            report(done)
    else:
        document = dict(resolved.document)
        futures: dict[Future[list[GroupResult | str]], list[StaleDiagnosis]] = {
            executor.submit(rediagnose_chunk, document, resolved.version, groups): chunk
            for chunk, groups in chunks}
        try:
            for future in as_done(futures, waiting):
                chunk = futures[future]
                _save(sessions, plan, chunk, future.result(), tally)
                done += len(chunk)
                report(done)
        except BaseException:  # a cancelled job (or a failure): the chunks not started go
            for future in futures:
                future.cancel()
            raise
    replaced = sorted(tally["replaced"], key=lambda r: r["diagnosis_id"])
    return {"rig_id": resolved.rig_id, "rig_version": resolved.version,
            "versions": list(plan.versions), "n_diagnoses": total,
            "rediagnosed": len(replaced),
            "changed": sum(1 for r in replaced if r["before"] != r["after"]),
            "skipped": tally["skipped"], "remaining": plan.remaining, "replaced": replaced,
            "errors": sorted(tally["errors"], key=lambda e: e["diagnosis_id"])}

