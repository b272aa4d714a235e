"""Measured records written back as one file in the import format (:mod:`diagnostics.timeseries`).

An adapter's records (a public data set's cycles, a logger's runs) written here are what
``POST /rigs/{id}/series`` and ``hydrodiag import series`` read as they are: one row per
sample, ``t [s]``, a ``record`` column, every channel as ``name [SI unit]``, the records'
conditions as constant columns (:meth:`SeriesRecord.frame`).

Clock times: a record's :attr:`SeriesRecord.started_at` is kept by writing the earliest of
them as the file's ``started_at`` (the ``# started_at = "..."`` header line of a CSV, the
``hydrodiag`` metadata of a Parquet file) and moving each record's ``t`` by its own start's
distance from it, so that the import gives every record back its own ``measured_at``
(the reader's rule: the file's start plus the record's first ``t``).  Records either all
have a start or none.
"""

from __future__ import annotations

import gzip
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from diagnostics.table_files import table_bytes
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError

__all__ = ["SUFFIXES", "series_table", "write_series"]

#: the file names :func:`write_series` writes (and the import reads by them)
SUFFIXES = (".csv", ".csv.gz", ".parquet")


def series_table(records: Sequence[SeriesRecord]) -> tuple[pd.DataFrame, dict[str, str]]:
    """The records as one long table and its header entries (``started_at`` when known).

    Raises
    ------
    InputError
        No record, two records of one name (the import would merge them), or some records
        with a clock time and some without (``field="started_at"``).
    """
    if not records:
        raise InputError("no record to write", field="records")
    names = [r.name for r in records]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InputError(f"record {twice[0]!r} twice: the import would read one record",
                         field="records")
    starts = [r.started_at for r in records]
    if any(s is None for s in starts) and any(s is not None for s in starts):
        raise InputError("some records have a clock time and some not", field="started_at")
    origin = min(s for s in starts if s is not None) if starts[0] is not None else None
    frames = []
    for r in records:
        frame = r.frame()
        if origin is not None and r.started_at is not None:
            frame["t [s]"] = frame["t [s]"] + (r.started_at - origin).total_seconds()
        frames.append(frame.assign(record=r.name))
    table = pd.concat(frames, ignore_index=True)
    table = table[["record", *[c for c in table.columns if c != "record"]]]
    header = {} if origin is None else {"started_at": origin.isoformat()}
    return table, header


def write_series(records: Sequence[SeriesRecord], path: Path) -> int:
    """Write the records to ``path`` — Parquet for a ``.parquet`` name, CSV for ``.csv``,
    gzip-compressed CSV for ``.csv.gz`` — and return the rows written.

    Raises
    ------
    InputError
        As :func:`series_table`, a name not ending in one of :data:`SUFFIXES`, or the file
        cannot be written (``field="file"``).
    """
    if not path.name.endswith(SUFFIXES):
        raise InputError(f"{path.name}: a series file is {', '.join(SUFFIXES)} (the import "
                         "reads it by its name)", field="file")
    table, header = series_table(records)
    data = table_bytes(table, header, "parquet" if path.suffix == ".parquet" else "csv")
    try:
        path.write_bytes(gzip.compress(data, mtime=0) if path.suffix == ".gz" else data)
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror}", field="file") from None
    return len(table)
