"""Import measured time series as measurements of a rig, and read them back (issue 12).

Used by ``POST /rigs/{rig_id}/series``, ``GET /rigs/{rig_id}/series``, ``GET /series/{id}``
and ``hydrodiag import``.  Files are read by the one import path,
:func:`diagnostics.timeseries.read_series` (units in the column names or a column map with
units, a ``record`` column for several records, a sample rate for files without time); each
record becomes one row of ``measured_series`` in SI units.  A file with any bad column is
refused whole: nothing is stored.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from datetime import datetime, timedelta
from typing import Any

import numpy as np
from sqlalchemy import or_, select, true
from sqlalchemy.orm import Session, defer

from app.db.models import MeasuredSeries
from app.limits import check_file
from app.schemas.series import import_name_problem
from app.schemas.times import measurement_time_problem
from app.services.common import commit, get_or_raise, paginate
from app.services.rig_channels import column_of, rig_channels
from app.services.rigs import get_rig, lock_rig
from diagnostics.map_notes import unmatched_map_notes
from diagnostics.sampling import sampling_notes
from diagnostics.table_files import time_in_name as time_in_name_of
from diagnostics.timeseries import (
    ColumnEntry,
    SeriesRecord,
    column_entry,
    read_series,
)
from sim.errors import ConflictError, InputError, NotFoundError

__all__ = [
    "MAX_SERIES_BYTES",
    "as_record",
    "check_source",
    "delete_series",
    "get_series",
    "import_series",
    "list_series",
    "parse_column_map",
    "store_records",
    "stored_records",
    "upload_start",
]

#: Largest time-series file accepted [byte].
MAX_SERIES_BYTES = 20 * 1024 * 1024


def parse_column_map(text: str | None, *, field: str = "column_map"
                     ) -> dict[str, ColumnEntry] | None:
    """The column map given as JSON ``{"raw": ["channel", "unit"]}`` (or ``["channel",
    "unit", gain, offset]`` for a raw signal, ``["skip", "-"]`` for a column to leave out;
    :mod:`diagnostics.timeseries`); None when absent."""
    if text is None or not text.strip():
        return None
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON: {exc.msg}", field=field) from None
    if not isinstance(raw, dict):
        raise InputError("must be a JSON object raw column → [channel, unit]", field=field)
    out: dict[str, ColumnEntry] = {}
    for key, value in raw.items():
        if (not isinstance(value, list) or len(value) not in (2, 4)
                or not all(isinstance(v, str) and v for v in value[:2])
                or not all(isinstance(v, int | float) and not isinstance(v, bool)
                           for v in value[2:])):
            raise InputError("each entry must be [channel, unit] or [channel, unit, gain, "
                             "offset] (numbers)", field=f"{field}.{key}")
        entry: ColumnEntry = ((value[0], value[1]) if len(value) == 2
                              else (value[0], value[1], float(value[2]), float(value[3])))
        try:  # the reader's own check of a calibration, named as a field of the map
            column_entry(str(key), entry)
        except InputError as exc:
            raise InputError(exc.message, field=f"{field}.{key}") from None
        out[str(key)] = entry
    return out


def _same_times(a: Sequence[float] | None, b: Sequence[float] | None) -> bool:
    """Whether two records' sample times are the same counted from each one's first sample
    (to a thousandth of a sample period): the caller has matched their clock times, which
    place the first samples.  A table that counts a campaign's cycles from the file's start
    (``import zema --table`` with ``--started-at``) holds the cycles the CLI stores from 0;
    compared as stored, all but the earliest cycle were stored a second time (a user pass)."""
    if a == b:
        return True
    if a is None or b is None or len(a) != len(b) or len(a) == 0:
        return False
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    step = float(np.median(np.diff(x))) if x.size > 1 else 1.0
    return bool(np.allclose(x - x[0], y - y[0], rtol=0.0, atol=1e-3 * abs(step)))


def _same_samples(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether two stored records hold the same samples: the same times (:func:`_same_times`)
    and the same channels' values, whatever the channels are named (the same cycles
    imported again with the map's names changed were stored four times; a real-data
    analyst's pass)."""
    if not _same_times(a.get("t"), b.get("t")):
        return False
    ca, cb = a.get("channels") or {}, b.get("channels") or {}
    if ca == cb:
        return True
    if len(ca) != len(cb):
        return False
    # the channels' first samples first: a campaign's cycles share their times, and a
    # whole comparison of every pair cost O(channels²·samples) each
    head = sorted(list(v[:4]) for v in ca.values()) == sorted(list(v[:4]) for v in cb.values())
    return head and sorted(list(v) for v in ca.values()) == sorted(list(v) for v in cb.values())


def _refuse_stored_twice(session: Session, rig_id: int, name: str,
                        rows: Sequence[MeasuredSeries],
                        compared: Sequence[set[int]] | None = None) -> list[set[int]]:
    """Raise :class:`ConflictError` if a row of ``rows`` is stored already for the rig: the
    same samples from the same start time (or both without one), under whatever name or
    file name — the same import run twice, after which a discrepancy check of the campaign
    counted each cycle twice, and as a repeat in its lack-of-fit test.  (The check keyed on
    the name and the record's label, which comes from the file's name: the same file copied
    or uploaded under another name was stored twice; a fleet pass.  Then on the channels'
    names: :func:`_same_samples`.)  A logger that writes
    each day's file under one name is no duplicate: its data differ.  Returns, per row, the
    ids of the stored rows it was compared with; ``compared``: those are not compared again
    (the second look, under the write lock, at what was stored since the first)."""
    found: list[tuple[MeasuredSeries, MeasuredSeries]] = []
    looked: list[set[int]] = []
    for k, row in enumerate(rows):
        skip = compared[k] if compared is not None else set()
        looked.append(set())
        # a start stated on one import and not on the other is no other measurement (the
        # same file imported with and without --started-at was stored twice, and a check
        # held out a record it had trained on: a discrepancy pass)
        same_time = (true() if row.measured_at is None
                     else or_(MeasuredSeries.measured_at.is_(None),
                              MeasuredSeries.measured_at == row.measured_at))
        for stored in session.scalars(
                select(MeasuredSeries).where(
                    MeasuredSeries.rig_id == rig_id,
                    MeasuredSeries.n_samples == row.n_samples, same_time,
                    MeasuredSeries.id.not_in(skip) if skip else true())):
            looked[k].add(stored.id)
            if _same_samples(stored.data, row.data):
                found.append((stored, row))
    if found:  # the twins from the same start first, then those with a start on one side
        found.sort(key=lambda pair: (pair[0].measured_at != pair[1].measured_at, pair[0].id))
        ids = ", ".join(str(s.id) for s, _ in found[:5]) + (" …" if len(found) > 5 else "")
        first, new = found[0]
        restated = ""
        if dict(first.condition or {}) != dict(new.condition or {}):
            # a stated condition corrected (kN typed under [N]) is refused as the same
            # samples; say so, and how to replace it (a discrepancy pass)
            restated = (f"; series {first.id} states the condition {dict(first.condition)}, "
                        f"this import {dict(new.condition)}: to correct a stated condition, "
                        f"delete series {first.id} (DELETE /series/{first.id}; hydrodiag "
                        f"rigs series {rig_id} --delete {first.id}) and import again")
        raise ConflictError(
            f"{len(found)} of these records are stored already for rig {rig_id}, the same "
            f"samples (series {ids}; the first as {first.name!r}, record {first.record!r}): "
            f"nothing to import under {name!r} (stored twice, a cycle would count twice in a "
            "discrepancy check); to import them again, delete those series first (DELETE "
            f"/series/{{id}}; hydrodiag rigs series {rig_id} --delete ID)" + restated,
            field="file")
    return looked


def store_records(session: Session, rig_id: int, name: str, records: Sequence[SeriesRecord],
                  progress: Callable[[int, int], None] | None = None) -> list[MeasuredSeries]:
    """Store ``records`` as measurements of rig ``rig_id`` (one transaction).

    Raises
    ------
    NotFoundError
        No rig ``rig_id``.
    InputError
        No records.
    ConflictError
        A record's samples stored already for the rig, under any name (``field="file"``).
    """
    get_rig(session, rig_id, field="rig_id")
    problem = import_name_problem(name)
    if problem is not None:
        raise InputError(problem, field="name")
    if not records:
        raise InputError("the file holds no record", field="file")
    for r in records:  # a time from the file's header or its name, as a given started_at
        problem = None if r.measured_at is None else measurement_time_problem(r.measured_at)
        if problem is not None:
            raise InputError(f"record {r.name!r} would be stored as measured at {problem}",
                             field="started_at")
    rows = []
    for k, r in enumerate(records):
        rate = r.sample_rate
        # a file name that is not UTF-8 (a logger's Latin-1 name) keeps a '?' for each byte
        record = r.name.encode("utf-8", errors="replace").decode("utf-8")[:200]
        rows.append(MeasuredSeries(
            rig_id=rig_id, name=name, record=record, sample_rate=rate,
            n_samples=len(r), measured=r.measured, units=dict(r.units),
            condition=dict(r.condition), measured_at=r.measured_at,
            data={"t": r.t.tolist(), "channels": {c: v.tolist() for c, v in r.channels.items()}}
            | ({} if r.phase is None else {"phase": [str(x) for x in r.phase]}),
        ))
        if progress is not None:
            progress(k + 1, len(records))
    # the whole comparison first, without the lock (300 stored cycles held the store's write
    # lock 17 s, and other writes got 503s: a verification pass); then, under the rig's write
    # lock, again against what was stored since, and the insert in the same transaction
    # (the same file sent by ten clients at once was stored 2-4 times: an SRE pass)
    compared = _refuse_stored_twice(session, rig_id, name, rows)
    lock_rig(session, rig_id)
    _refuse_stored_twice(session, rig_id, name, rows, compared)
    session.add_all(rows)
    commit(session, conflict="the series could not be stored")
    return rows


def upload_start(filename: str | None, started_at: datetime | None,
                 time_in_name: str | None, zone: str | None, *,
                 names: tuple[str, str, str] = ("started_at", "time_in_name", "zone")
                 ) -> datetime | None:
    """The clock time at which an uploaded file's ``t`` reads 0 [UTC]: ``started_at``, or
    the time the logger wrote into ``filename`` read with the strptime format
    ``time_in_name`` in ``zone`` (:func:`diagnostics.table_files.time_in_name`; a ``.gz``
    suffix left out); None when neither is given (the file's header may hold it).
    ``names``: what the caller calls the three (the form's fields, the CLI's options).

    Raises
    ------
    InputError
        Both ``started_at`` and ``time_in_name``, a ``zone`` without ``time_in_name``, an
        upload without a file name, or no such time in it (naming the field or option).
    """
    start_name, format_name, zone_name = names
    if time_in_name is None:
        if zone is not None:
            raise InputError(f"{zone_name} goes with {format_name}", field=zone_name)
        return started_at
    if started_at is not None:
        raise InputError(f"give {start_name} or {format_name}, not both", field=start_name)
    if not filename:
        raise InputError("the upload has no file name to read the time from",
                         field=format_name)
    return time_in_name_of(filename.removesuffix(".gz"), time_in_name, zone,
                           field=format_name, zone_field=zone_name)


def import_series(session: Session, rig_id: int, name: str, content: bytes, *,
                  column_map: dict[str, ColumnEntry] | None = None,
                  sample_rate: float | None = None, fmt: str | None = None,
                  started_at: datetime | None = None, filename: str | None = None,
                  time_in_name: str | None = None, zone: str | None = None
                  ) -> tuple[list[MeasuredSeries], list[str]]:
    """Read a CSV/Parquet file and store its records (errors name ``file.<column>``), and
    say which channels the rig does not know (:meth:`~app.services.rig_channels.RigChannels.notes`);
    ``started_at``: the clock time at which the file's ``t`` reads 0 [UTC] (or read from
    ``filename`` by ``time_in_name`` and ``zone``: :func:`upload_start`), else the file
    header's (:mod:`diagnostics.timeseries`); ``filename`` names a record without a
    ``record`` column."""
    channels = rig_channels(session, rig_id)
    started_at = upload_start(filename, started_at, time_in_name, zone)
    check_file(content, MAX_SERIES_BYTES, field="file")
    try:
        records = read_series(content, format=fmt, column_map=column_map,
                              expected=channels.units,
                              sample_rate=sample_rate, started_at=started_at,
                              name=filename.removesuffix(".gz") if filename else None,
                              max_bytes=MAX_SERIES_BYTES)
    except InputError as exc:
        where = exc.field if exc.field in ("column_map", "sample_rate") else (
            f"file.{exc.field}" if exc.field and exc.field != "file" else "file")
        raise type(exc)(exc.message, field=where) from None
    try:
        channels.check_plateaus(records)
    except InputError as exc:  # the user's column, as every other error of a file names it
        raise InputError(exc.message, field=f"file.{column_of(exc.field, column_map)}") from None
    rows = store_records(session, rig_id, name, records)
    return rows, (unmatched_map_notes(column_map, records) + channels.notes(rows)
                  + channels.time_notes(records) + sampling_notes(records, sample_rate))


def list_series(session: Session, rig_id: int, *, limit: int, offset: int
                ) -> tuple[Sequence[MeasuredSeries], int]:
    """A page of the rig's stored records, in order of import, without their samples (a
    listing shows none: read whole, the 2,215 ZeMA cycles took 249 ms to list; a
    store-scale pass)."""
    get_rig(session, rig_id, field="rig_id")
    statement = (select(MeasuredSeries).where(MeasuredSeries.rig_id == rig_id)
                 .options(defer(MeasuredSeries.data, raiseload=True))
                 .order_by(MeasuredSeries.id))
    return paginate(session, statement, limit=limit, offset=offset)


def get_series(session: Session, series_id: int) -> MeasuredSeries:
    """The stored record ``series_id`` (:class:`NotFoundError` when absent)."""
    return get_or_raise(session, MeasuredSeries, series_id, what="series", field="series_id")


def check_source(session: Session, series_id: int, rig_id: int, *, field: str) -> None:
    """Check that a record read from stored series ``series_id`` names that series' rig.

    Raises
    ------
    NotFoundError
        No such series (``field``).
    InputError
        The series belongs to another rig (``field``).
    """
    row = get_or_raise(session, MeasuredSeries, series_id, what="series", field=field)
    if row.rig_id != rig_id:
        raise InputError(f"series {series_id} belongs to rig {row.rig_id}, not rig {rig_id}",
                         field=field)


def delete_series(session: Session, series_id: int) -> None:
    """Delete the stored record ``series_id`` (:class:`NotFoundError` when absent).  Nothing
    refers to it: a record read from it and diagnosed is stored in the history on its own,
    and jobs keep the ids they were given as text."""
    session.delete(get_series(session, series_id))
    commit(session, conflict=f"series {series_id} could not be deleted", field="series_id")


def as_record(row: MeasuredSeries) -> SeriesRecord:
    """The stored record as the import path read it: samples, units, phases (where the file
    had a ``phase`` column), condition and clock time, marked measured or not as stored."""
    data = row.data
    phase = data.get("phase")
    t = np.asarray(data["t"], dtype=float)
    start = (None if row.measured_at is None
             else row.measured_at - timedelta(seconds=float(t[0])))
    return SeriesRecord(row.record, t,
                        {c: np.asarray(v, dtype=float) for c, v in data["channels"].items()},
                        dict(row.units), None if phase is None else np.asarray(phase, dtype=str),
                        {k: float(v) for k, v in row.condition.items()},
                        {"series_id": row.id, "import": row.name}, row.measured, start)


def stored_records(session: Session, rig_id: int, ids: Sequence[int], *,
                   field: str = "series_ids") -> list[SeriesRecord]:
    """The stored records ``ids`` of rig ``rig_id``, in the order given.

    Raises
    ------
    InputError
        No ids, an id given twice, or a record of another rig (``field``).
    NotFoundError
        An id names no stored record.
    """
    if not ids:
        raise InputError("give at least one stored series id", field=field)
    if len(set(ids)) != len(ids):
        raise InputError("a series id is given twice", field=field)
    found = {r.id: r for r in session.scalars(  # one query: a campaign is thousands
        select(MeasuredSeries).where(MeasuredSeries.id.in_(ids)))}
    missing = [i for i in ids if i not in found]
    if missing:
        raise NotFoundError(f"no series with id {missing[0]}", field=field)
    rows = [found[i] for i in ids]
    other = [r.id for r in rows if r.rig_id != rig_id]
    if other:
        more = f" and {len(other) - 10} more" if len(other) > 10 else ""
        raise InputError(f"series {', '.join(map(str, other[:10]))}{more} "
                         f"{'belongs' if len(other) == 1 else 'belong'} to another rig, not rig "
                         f"{rig_id}", field=field)
    return [as_record(r) for r in rows]
