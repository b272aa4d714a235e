"""Table files as loggers and exports write them: the reading layer of :mod:`diagnostics.timeseries`.

A CSV or Parquet file, from a path or its bytes, gzip-compressed or not (one member or
several; a truncated stream or one past the size limit is refused), is read into a table
and its header: CSV files may start with ``# key = <json>`` lines (the ``/simulate``
export's: rig, condition, summary, ``started_at``), Parquet files carry the same entries as
JSON in their key-value metadata under :data:`PARQUET_METADATA_KEY`.  A CSV file's
separator (comma, semicolon or tab) and decimal mark are found from its first lines
(:func:`dialect`).  Errors are :class:`~sim.errors.InputError` naming ``file`` or
``format``.  :func:`table_bytes` writes a table and its header in the same layout, so
that what an export or an adapter writes reads back here as it was.
"""

from __future__ import annotations

import io
import itertools
import json
import operator
import re
import zlib
from collections.abc import Mapping
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path
from typing import Any, Literal

import pandas as pd

from sim.errors import InputError

__all__ = ["DECIMAL_COMMA", "MAX_DECOMPRESSED_BYTES", "PARQUET_METADATA_KEY", "check_table",
           "check_text", "dialect", "gunzipped", "read_csv_exact", "read_table", "stated_dialect",
           "table_bytes", "time_in_name"]

#: Largest gzip-compressed file's size once decompressed, unless the caller says [byte];
#: a Parquet file's decoded size too.
MAX_DECOMPRESSED_BYTES = 64 * 1024 * 1024
#: Most columns of a table [-]: a rig's channels, its time, phase, record and condition
#: columns are a few dozen; 200,000 columns held a worker for more than ten minutes (a
#: security review's pass).
MAX_COLUMNS = 1000
#: Key of the JSON header in a Parquet file's metadata (as ``/simulate`` writes it).
PARQUET_METADATA_KEY = "hydrodiag"

#: pandas before 3.1 reads some numbers written with 17 digits an ulp or so off by default;
#: its round-trip converter reads them exactly (3.1 made exact the default and deprecated the
#: option)
_ROUND_TRIP = tuple(int(part) for part in re.findall(r"\d+", pd.__version__)[:2]) < (3, 1)

_META = re.compile(r"^#\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.*)$")


def table_bytes(frame: pd.DataFrame, header: Mapping[str, Any],
                fmt: Literal["csv", "parquet"]) -> bytes:
    """``frame`` and its ``header`` as a file :func:`read_table` reads back to both.

    CSV: each header entry a ``# key = <json>`` line, then the column names, then the rows
    by Arrow's writer (numbers as the shortest text that reads back to the same double;
    ~10x faster than pandas'), a text value quoted only where the file has one that holds
    a separator, quote or line break.  Parquet: the header as JSON in the file's metadata
    under :data:`PARQUET_METADATA_KEY`.
    """
    import pyarrow as pa

    table = pa.Table.from_pandas(frame, preserve_index=False)
    buffer = io.BytesIO()
    if fmt == "parquet":
        import pyarrow.parquet as pq

        metadata = dict(table.schema.metadata or {})
        metadata[PARQUET_METADATA_KEY.encode()] = json.dumps(dict(header)).encode("utf-8")
        pq.write_table(table.replace_schema_metadata(metadata), buffer)
        return buffer.getvalue()
    import pyarrow.csv as pcsv

    structural = re.compile(r'[,"\r\n]')
    texts = [frame[c] for c in frame.columns if not pd.api.types.is_numeric_dtype(frame[c])]
    quoted = any(s.astype(str).str.contains(structural).any() for s in texts)
    names = [f'"{n}"' if structural.search(str(n)) else str(n)
             for n in (str(c).replace('"', '""') for c in frame.columns)]
    lines = [f"# {key} = {json.dumps(value)}" for key, value in header.items()]
    buffer.write(("\n".join([*lines, ",".join(names)]) + "\n").encode("utf-8"))
    pcsv.write_csv(table, buffer, pcsv.WriteOptions(
        include_header=False, quoting_style="needed" if quoted else "none"))
    return buffer.getvalue()


def _header_lines(text: str) -> tuple[dict[str, Any], int]:
    """The ``# key = <json>`` lines at the top of a CSV text, parsed, and how many lines
    the header holds."""
    meta: dict[str, Any] = {}
    skipped = 0
    for line in io.StringIO(text):  # lazily: the header is a few lines of a long file
        line = line.rstrip("\r\n")
        if not line.startswith("#"):
            break
        skipped += 1
        m = _META.match(line)
        if m is not None:
            try:
                meta[m.group(1)] = json.loads(m.group(2))
            except json.JSONDecodeError:
                meta[m.group(1)] = m.group(2).strip()
    return meta, skipped


def gunzipped(raw: bytes, max_bytes: int) -> bytes:
    """``raw`` decompressed when it is gzip data (its magic bytes), else as it is.

    Raises
    ------
    InputError
        Broken gzip data, or more than ``max_bytes`` once decompressed (``file``).
    """
    if raw[:2] != b"\x1f\x8b":
        return raw
    parts: list[bytes] = []
    size = 0
    rest = raw
    while rest:  # member by member: a gzip file may hold several
        inflate = zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)
        try:
            part = inflate.decompress(rest, max_bytes + 1 - size)
        except zlib.error as exc:
            raise InputError(f"not readable gzip data: {exc}", field="file") from None
        size += len(part)
        if size > max_bytes:
            raise InputError(f"the file is more than {max_bytes} bytes decompressed",
                             field="file")
        if not inflate.eof:
            raise InputError("the gzip data end before their end (a truncated file?)",
                             field="file")
        parts.append(part)
        rest = inflate.unused_data
    return b"".join(parts)


def read_table(source: str | Path | bytes | pd.DataFrame, fmt: str | None = None,
               max_bytes: int = MAX_DECOMPRESSED_BYTES
               ) -> tuple[pd.DataFrame, dict[str, Any], str]:
    """The table of a CSV or Parquet file (a path or its bytes, gzip-compressed or not) or a
    table given as it is, its header entries (CSV ``# key = <json>`` lines, Parquet
    metadata under :data:`PARQUET_METADATA_KEY`) and the source's name (the file's without
    ``.gz``; ``upload`` for bytes, ``table`` for a table).

    Raises
    ------
    InputError
        The file cannot be read, decompressed (beyond ``max_bytes`` [byte]) or parsed, or
        ``fmt`` is neither ``csv`` nor ``parquet`` (``file``, ``format``).
    """
    if isinstance(source, pd.DataFrame):
        return source, {}, "table"
    name = "upload"
    if isinstance(source, str | Path):
        path = Path(source)
        name = path.name.removesuffix(".gz")
        fmt = fmt or ("parquet" if Path(name).suffix.lower() in (".parquet", ".pq") else "csv")
        try:
            raw = gunzipped(path.read_bytes(), max_bytes)
        except OSError as exc:
            raise InputError(f"cannot read {path}: {exc.strerror}", field="file") from None
    else:
        raw = gunzipped(bytes(source), max_bytes)
        fmt = fmt or ("parquet" if raw[:4] == b"PAR1" else "csv")
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:
            _check_parquet_size(pq.ParquetFile(io.BytesIO(raw)).metadata, max_bytes)
            table = pq.read_table(io.BytesIO(raw))
        except (pa.ArrowException, OSError) as exc:
            raise InputError(f"not a readable Parquet file: {exc}", field="file") from None
        meta: dict[str, Any] = {}
        blob = (table.schema.metadata or {}).get(PARQUET_METADATA_KEY.encode())
        if blob is not None:
            try:
                meta = dict(json.loads(blob.decode("utf-8")))
            except (ValueError, UnicodeDecodeError):
                meta = {}
        return table.to_pandas(), meta, name
    if fmt != "csv":
        raise InputError(f"unknown format {fmt!r} (csv or parquet)", field="format")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"the CSV file is not UTF-8 text (byte {exc.start + 1} reads "
                         f"{raw[exc.start:exc.start + 1]!r}: a Windows code page such as "
                         "cp1252?); save it as UTF-8 (Excel: 'CSV UTF-8')", field="file") from None
    check_text(text, "file")
    meta, skip = _header_lines(text)
    lines = [ln.rstrip("\r\n") for ln in itertools.islice(io.StringIO(text), skip, skip + 7)]
    stated, sep, decimal = stated_dialect(lines)
    # every line's fields, not the header's alone: rows of 200,000 fields under a header
    # of three held a worker for 16.5 s before pandas refused them (a verification pass)
    _check_columns(max(map(operator.methodcaller("count", sep), io.StringIO(text)),
                       default=-1) + 1)     # line by line: no list of a 64 MiB file's lines
    skip, lines = skip + stated, lines[stated:]
    try:
        frame = read_csv_exact(io.StringIO(text), skiprows=skip, comment=None, sep=sep,
                               decimal=decimal)
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise InputError(f"not a readable CSV table: {exc}", field="file") from None
    check_table(frame, "file")
    return _named_columns(frame, lines[0].split(sep) if lines else []), meta, name


def _check_columns(count: int) -> None:
    """Refuse a table of more than :data:`MAX_COLUMNS` columns, before any work per column."""
    if count > MAX_COLUMNS:
        raise InputError(f"the table has {count:,} columns, more than the {MAX_COLUMNS:,} a "
                         "table may have (a rig's channels with time, phase, record and "
                         "condition columns are a few dozen)", field="file")


#: bytes a value of a Parquet physical type takes once decoded (a run of zeros encodes to
#: a few bytes: the file's sizes say nothing of it)
_PARQUET_WIDTHS = {"BOOLEAN": 1, "INT32": 4, "FLOAT": 4, "INT64": 8, "DOUBLE": 8, "INT96": 12}


def _check_parquet_size(metadata: Any, max_bytes: int) -> None:
    """Refuse a Parquet file before it is decoded when it has more than
    :data:`MAX_COLUMNS` columns or decodes to more than ``max_bytes`` [byte]: a 262 kB file
    of zeros decoded to 480 MB and grew a worker by 1 GB (a security review's pass)."""
    _check_columns(metadata.num_columns)
    decoded = 0
    for i in range(metadata.num_row_groups):
        group = metadata.row_group(i)
        for j in range(group.num_columns):
            chunk = group.column(j)
            width = _PARQUET_WIDTHS.get(chunk.physical_type)
            if width is None:   # text: its longest value where the statistics give it,
                # else its encoded size per value (72 bytes a value refused a 15.5 MiB
                # table as 22 MiB: a verification pass)
                stats = chunk.statistics
                longest = (max(len(str(stats.min)), len(str(stats.max)))
                           if stats is not None and stats.has_min_max else
                           chunk.total_uncompressed_size / max(chunk.num_values, 1))
                width = int(longest) + 8
            decoded += chunk.num_values * width
    if decoded > max_bytes:
        raise InputError(f"the Parquet file decodes to {decoded / 2**20:.0f} MiB, more than the "
                         f"{max_bytes / 2**20:.0f} MiB a table may have", field="file")


#: Excel's first line stating the separator of a CSV file
_EXCEL_SEP = re.compile(r"^\ufeff?sep=(.)$")


def stated_dialect(lines: list[str]) -> tuple[int, str, str]:
    """:func:`dialect` of a CSV table's first lines, where Excel's first line ``sep=;``
    states the separator: ``(lines to skip, 0 or 1, separator, decimal mark)`` — the time
    series and the record tables alike (the line was a tokenizer error: an analyst's
    pass)."""
    stated = _EXCEL_SEP.match(lines[0].strip()) if lines else None
    skip = 0 if stated is None else 1
    sep, decimal = dialect(lines[skip:skip + 6])
    if stated is not None:
        sep = stated.group(1)
        decimal = decimal if sep != "," else "."
    return skip, sep, decimal


def _named_columns(frame: pd.DataFrame, header: list[str]) -> pd.DataFrame:
    """``frame`` with its header checked as written: a name given twice refused naming it
    and its columns (pandas read the second as ``name.1``, then refused for a unit missing
    from brackets), a column without a name refused by its position (``Unnamed: 7``), and
    an unnamed column that is empty throughout — a trailing delimiter on every line, as
    loggers write — left out."""
    names = [h.strip().strip('"') for h in header]
    if len(names) != len(frame.columns):  # quoted separators in the header: as pandas read it
        return frame
    seen: dict[str, int] = {}
    for k, h in enumerate(names):
        if h and h in seen:
            raise InputError(f"the header names {h!r} twice (columns {seen[h] + 1} and "
                             f"{k + 1}): rename or remove one", field=h)
        seen.setdefault(h, k)
    for k, col in enumerate(list(frame.columns)):
        if str(col).startswith("Unnamed: ") and k < len(names) and not names[k]:
            if frame[col].isna().all():
                frame = frame.drop(columns=col)
                continue
            raise InputError(f"column {k + 1} has no name in the header: give it one "
                             "('name [unit]') or remove it", field=f"column {k + 1}")
    return frame


def check_table(frame: pd.DataFrame, field: str) -> None:
    """Refuse a table pandas read with its leading columns as the index: rows with more
    fields than the header, as decimal commas in a comma-separated file give (a user pass:
    "7.7e13 °C is outside …" was the first sign)."""
    if not isinstance(frame.index, pd.RangeIndex):
        extra = frame.index.nlevels
        raise InputError(f"the rows have {extra} more field(s) than the header's "
                         f"{len(frame.columns)}: decimal commas in a comma-separated file? "
                         "separate the fields with ';' or write decimals with '.'",
                         field=field)


def check_text(text: str, field: str) -> None:
    """Refuse text with NUL characters: a binary file, not a table."""
    if "\x00" in text:
        raise InputError("the file is binary, not a text table", field=field)


DECIMAL_COMMA = re.compile(r"^\s*[-+]?\d+,\d+([eE][-+]?\d+)?\s*$")
_DECIMAL_POINT = re.compile(r"^\s*[-+]?\d*\.\d+([eE][-+]?\d+)?\s*$")


def read_csv_exact(text: io.StringIO, **options: Any) -> pd.DataFrame:
    """``pandas.read_csv`` of a whole table whose numbers, written with 17 significant
    digits, read back exactly on every pandas the project supports."""
    if _ROUND_TRIP:
        options["float_precision"] = "round_trip"
    frame: pd.DataFrame = pd.read_csv(text, **options)
    return frame


def dialect(lines: list[str]) -> tuple[str, str]:
    """The separator and decimal mark of a CSV table from its first lines (the header and a
    few rows): the one of tab, semicolon and comma that splits every line into the same
    number (> 1) of fields, preferring tab, then semicolon, then comma (a comma may be a
    decimal mark); a semicolon- or tab-separated table with numbers like ``1,5`` and none
    like ``1.5`` has decimal commas."""
    lines = [ln for ln in lines if ln.strip()]
    sep = ","
    for cand in ("\t", ";"):
        counts = {ln.count(cand) for ln in lines}
        if lines and len(counts) == 1 and counts.pop() > 0:
            sep = cand
            break
    if sep == ",":
        return sep, "."
    cells = [c for ln in lines[1:] for c in ln.split(sep)]
    comma = any(DECIMAL_COMMA.match(c) for c in cells)
    point = any(_DECIMAL_POINT.match(c) for c in cells)
    return sep, "," if comma and not point else "."


#: strptime directives a file name's time may use, as the text each matches
_DIRECTIVES = {"Y": r"\d{4}", "y": r"\d{2}", "m": r"\d{1,2}", "d": r"\d{1,2}",
               "H": r"\d{1,2}", "I": r"\d{1,2}", "M": r"\d{1,2}", "S": r"\d{1,2}",
               "f": r"\d{1,6}", "j": r"\d{1,3}", "p": r"(?:AM|PM|am|pm)",
               "b": r"[A-Za-z]{3}", "z": r"(?:Z|[+-]\d{2}:?\d{2})", "%": "%"}
_ZONE = re.compile(r"^(?:Z|([+-])(\d{2}):?(\d{2}))$")


def _zone(text: str, field: str) -> timezone:
    m = _ZONE.match(text.strip())
    if m is None:
        raise InputError(f"{text!r} is not a UTC offset (Z, +02:00, -0400)", field=field)
    if m.group(1) is None:
        return UTC
    hours, minutes = int(m.group(2)), int(m.group(3))
    if hours > 14 or minutes >= 60:  # civil offsets run from -12:00 to +14:00
        raise InputError(f"{text!r} is not a UTC offset: at most 14 hours and 59 minutes",
                         field=field)
    minutes += 60 * hours
    return timezone(timedelta(minutes=minutes if m.group(1) == "+" else -minutes))


def time_in_name(name: str, fmt: str, zone: str | None = None, *,
                 field: str = "time_in_name", zone_field: str = "zone") -> datetime:
    """The clock time a logger wrote into a file's ``name``, in UTC: the first part of the
    name that reads as ``fmt`` (strptime directives ``%Y %y %m %d %H %I %M %S %f %j %p %b
    %z``; e.g. ``%m-%d-%Y-%I-%M-%S %p`` finds ``9-10-2019-4-37-01 PM``), in the time zone
    ``zone`` (``Z``, ``+02:00``) unless ``fmt`` has ``%z``.

    Raises
    ------
    InputError
        A directive not supported, no zone (or two), no such time in the name (``field``;
        ``zone_field`` for a bad offset).
    """
    pattern, k = [], 0
    while k < len(fmt):
        if fmt[k] == "%":
            code = fmt[k + 1:k + 2]
            if code not in _DIRECTIVES:
                raise InputError(f"%{code} is not a directive a file name's time may use (use "
                                 "%Y %y %m %d %H %I %M %S %f %j %p %b %z)", field=field)
            pattern.append(_DIRECTIVES[code])
            k += 2
        else:
            pattern.append(re.escape(fmt[k]))
            k += 1
    has_zone = "%z" in fmt
    if has_zone == (zone is not None):
        raise InputError("give the time zone once: %z in the format, or the zone (Z, +02:00)",
                         field=field)
    for m in re.finditer("(?=(" + "".join(pattern) + "))", name):
        try:
            when = datetime.strptime(m.group(1), fmt)
        except ValueError:
            continue  # e.g. month 13: the next place in the name may read
        if zone is not None:
            when = when.replace(tzinfo=_zone(zone, zone_field))
        return when.astimezone(UTC)
    raise InputError(f"no time of the form {fmt!r} in the file name {name!r}", field=field)
