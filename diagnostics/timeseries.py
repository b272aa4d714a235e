"""Measured time series as users have them: tables with units in the column names.

This is hydrodiag's one import path for measured (or simulated) time series.  The format
is exactly what ``POST /simulate`` exports (:mod:`app.services.simulation`): one row per
sample, a time column ``t [s]``, one column per channel named ``name [unit]``, optionally a
``phase`` column (``working``/``return``) and a ``record`` column that separates several
records (cycles, runs at different loads or temperatures) in one file.  CSV files may
start with ``# key = <json>`` lines (the export's header: rig, condition, summary);
Parquet files carry the same header as JSON in their key-value metadata under
``hydrodiag``.

Every value is converted to SI on reading (:mod:`sim.units`; temperatures stay in °C, the
project's unit for oil temperature, and kelvin is converted to it).  Validation names the
column: an unknown or wrong unit, a missing required channel, a NaN or infinite value, a
time that does not increase within a record, a record with fewer than two samples.

Condition channels — ``load [N]``, ``back_pressure [Pa]``, ``oil_temperature [degC]``,
``pump_speed [rad/s]`` — that are constant within a record become the record's
:attr:`SeriesRecord.condition`; the export's ``# condition = {...}`` header line does the
same for a single-record file.  A varying temperature stays a channel as well.

A record's clock time: ``started_at`` (a keyword of :func:`read_series`, or the header line
``# started_at = "2026-11-20T08:00:00Z"``) is the time [UTC, ISO 8601 with its zone] at
which the file's ``t`` reads 0; each record's :attr:`SeriesRecord.measured_at` is that plus
its first sample's ``t`` (records whose time restarts at 0, or a file read by its sample
rate, all get the start).  Without it a record has no clock time.

A *column map* adapts other tables (a data logger's, a public data set's): raw column →
``(channel, unit)``, e.g. ``{"PS1": ("P_pump", "bar")}``; mapped columns need no unit in
their names, and a logger's own record or stroke column maps to ``("record", "-")`` or
``("phase", "-")`` (a numeric spool command, N = +1 / −1 as paper 002 writes it, reads as
``working`` / ``return``).  A raw signal (ADC counts, a transducer's volts or milliamps)
takes its linear calibration: ``(channel, unit, gain, offset)`` reads ``gain·raw + offset``
in ``unit`` (a 4-20 mA transducer of 0-250 bar: ``("P1", "bar", 15.625, -62.5)``; a
sample index at 500 Hz: ``("t", "s", 0.002, 0)``); ``("skip", "-")`` leaves a column out
(a logger's own notes or features).  A table without a time column needs its
``sample_rate`` [Hz].  CSV files may be separated by commas, semicolons or tabs (found from
the first lines); a semicolon- or tab-separated file whose numbers are written with a
decimal comma (``1,5``, as spreadsheets in many locales write them) is read so; a
gzip-compressed file is read decompressed.
:func:`read_series` is the entry point; :meth:`SeriesRecord.frame` writes a
record back in the same format.  The file layer (gzip, the CSV dialect, header lines and
Parquet metadata) is :mod:`diagnostics.table_files`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from diagnostics.channel_names import CONDITION_CHANNELS, series_channel_notes
from diagnostics.column_map import SKIP, ColumnEntry, column_entry, read_column_map
from diagnostics.series_record import SeriesRecord, clock_time, si_factor
from diagnostics.table_files import MAX_DECOMPRESSED_BYTES, PARQUET_METADATA_KEY, read_table
from sim.errors import InputError

__all__ = [
    "CONDITION_CHANNELS",
    "MAX_DECOMPRESSED_BYTES",
    "PARQUET_METADATA_KEY",
    "SKIP",
    "ColumnEntry",
    "SeriesRecord",
    "clock_time",
    "column_entry",
    "read_series",
    "series_from_frame",
    "si_factor",
]

#: Highest sample rate a file without a time column may state [Hz] (10 MHz: beyond any
#: logger of a hydraulic rig; 1e308 Hz gave times of 1e-308 s)
MAX_SAMPLE_RATE = 1.0e7

Arr = npt.NDArray[np.float64]


_COLUMN = re.compile(r"^\s*(.+?)\s*\[(.*)\]\s*$")
#: columns that are labels, not channels
_LABELS = ("phase", "record")


def _record_groups(frame: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    if "record" not in frame.columns:
        return [("", frame)]
    if frame["record"].isna().any():
        raise InputError("the record column has empty cells", field="record")
    return [(str(k), g) for k, g in frame.groupby("record", sort=False)]


def series_from_frame(frame: pd.DataFrame, *, name: str = "table",
                      column_map: Mapping[str, ColumnEntry] | None = None,
                      expected: Mapping[str, str] | None = None,
                      required: Sequence[str] = (), metadata: Mapping[str, Any] | None = None,
                      measured: bool = True, sample_rate: float | None = None,
                      started_at: datetime | None = None) -> list[SeriesRecord]:
    """Records of a table in the import format (module docstring).

    Parameters
    ----------
    frame
        The table.
    name
        Name of the source, used for a single record without a ``record`` column.
    column_map
        Raw column → ``(channel, unit)`` for columns without units in their names, or
        ``(channel, unit, gain, offset)`` for a raw signal (``gain·raw + offset`` in
        ``unit``); a column of labels maps to ``("record", "-")`` or ``("phase", "-")``,
        a column to leave out to ``("skip", "-")``.  A mapping: a list of pairs is
        refused (``dict(pairs)`` first).
    expected
        Channel → SI unit it must have (a rig's outputs, :meth:`sim.rigs.Rig.channels`);
        other channels take the SI unit of whatever unit they are written in.  A channel
        that is none of these, no condition channel and no pump flow meter (``Q_pump``)
        is kept and noted in each record's :attr:`SeriesRecord.notes`, with the nearest
        known name (a misspelt column map or header: :mod:`diagnostics.channel_names`).
        Not given, the channels are checked against those of every rig model hydrodiag
        builds (:func:`~diagnostics.channel_names.any_model_channels`): a name none has
        is noted, one that only another rig's model has is not (give the rig's channels
        for that).
    required
        Channels every record must have.
    metadata
        Header entries of the source; ``condition`` there fills the records' conditions.
    measured
        Whether the data are measured (True) or generated.
    sample_rate
        Samples per second [Hz] for a table without a time column: each record's times
        are then ``0, 1/rate, 2/rate, ...`` [s].  Ignored when the table has a time column.
    started_at
        Clock time at which ``t`` reads 0 [UTC, with its zone]; the header's
        ``started_at`` when None; the records' :attr:`SeriesRecord.started_at`.

    Raises
    ------
    InputError
        Naming the column: no time column (and no ``sample_rate``), unknown or wrong unit, NaN or infinity,
        non-increasing time, a required channel missing, a record of < 2 samples; a start
        without its zone (``started_at``).
    """
    cmap = read_column_map(column_map)
    labels: dict[str, str] = {}  # a logger's own record or phase column → the label
    for raw, (label, unit, gain, off) in [(r, c) for r, c in cmap.items()
                                          if c[0] in (*_LABELS, SKIP)]:
        del cmap[raw]
        if unit.strip() not in ("", "-", "1") or (gain, off) != (1.0, 0.0):
            what = ("'skip' leaves the column out" if label == SKIP
                    else f"{label!r} is a label column")
            raise InputError(f"{what}: its unit is '-' (not {unit!r}), without a calibration",
                             field=raw)
        if raw not in frame.columns or raw == label:  # unused entries, as for channels
            continue
        if label == SKIP:
            frame = frame.drop(columns=raw)
            continue
        if label in frame.columns or label in labels.values():
            raise InputError(f"the table has a {label!r} column already", field=raw)
        labels[raw] = label
    frame = frame.rename(columns=labels)
    exp = dict(CONDITION_CHANNELS, **(expected or {}))
    meta = dict(metadata or {})
    start = (clock_time(started_at) if started_at is not None
             else clock_time(meta["started_at"])
             if meta.get("started_at") is not None else None)
    columns: dict[str, tuple[str, str, float, float]] = {}  # raw → (channel, unit, scale, offset)
    seen: set[str] = set()
    for col in frame.columns:
        raw = str(col)
        if raw in _LABELS:
            continue
        gain, zero = 1.0, 0.0
        if raw in cmap:
            chan, unit, gain, zero = cmap[raw]
        else:
            m = _COLUMN.match(raw)
            if m is None:
                raise InputError("a column needs its unit in brackets ('P1 [bar]') or an "
                                 "entry in the column map (a column of labels: "
                                 "['record', '-'] or ['phase', '-'])", field=raw)
            chan, unit = m.group(1), m.group(2)
        canonical, scale, offset = si_factor(unit, column=raw, expected=exp.get(chan))
        if chan in seen:   # a set: a scan of the earlier columns was quadratic (a review)
            raise InputError(f"channel {chan!r} appears twice", field=raw)
        seen.add(chan)
        # SI = (gain·raw + zero)·scale + offset
        columns[raw] = (chan, canonical, gain * scale, zero * scale + offset)
    time_col = next((raw for raw, c in columns.items() if c[0] == "t"), None)
    if time_col is None and sample_rate is not None:
        if not (math.isfinite(sample_rate) and 0.0 < sample_rate <= MAX_SAMPLE_RATE):
            raise InputError(f"the sample rate must be above 0 and at most "
                             f"{MAX_SAMPLE_RATE:g} Hz", field="sample_rate")
    elif time_col is None:
        raise InputError("no time column: name it 't [s]' (or map one to 't'), or give the "
                         "sample rate", field="t")
    elif columns[time_col][1] != "s":
        raise InputError("the time column must be in a unit of time (s, ms, min, h)",
                         field=time_col)
    for chan in required:
        if chan not in (c[0] for c in columns.values()):
            raise InputError(f"required channel {chan!r} is missing", field=chan)
    notes = series_channel_notes([c[0] for c in columns.values() if c[0] != "t"], expected)
    found = meta.get("condition")
    header_condition: dict[str, Any] = dict(found) if isinstance(found, dict) else {}
    records: list[SeriesRecord] = []
    groups = _record_groups(frame)
    for key, group in groups:
        label = key or name
        values: dict[str, Arr] = {}
        for raw, (chan, _, scale, offset) in columns.items():
            try:
                data = pd.to_numeric(group[raw], errors="raise").to_numpy(dtype=float)
            except (ValueError, TypeError):
                raise InputError(_not_numbers(group[raw]), field=raw) from None
            bad = ~np.isfinite(data)
            if bad.any():
                row = int(np.argmax(bad))
                raise InputError(f"an empty cell, NaN or infinite value in record {label!r} at "
                                 f"its sample {row + 1} (counting from 1); a logger that writes "
                                 "its channels at different rates leaves cells empty: fill "
                                 "them forward or resample onto one rate", field=raw)
            values[chan] = data * scale + offset
            if columns[raw][1] == "degC":
                _check_temperature(values[chan], raw, label)
        if time_col is None:
            assert sample_rate is not None
            t = np.arange(len(group), dtype=float) / sample_rate
        else:
            t = values.pop("t")
        if t.size < 2:
            raise InputError(f"record {label!r} has fewer than two samples",
                             field=time_col or "t")
        steps = np.diff(t)
        if np.any(steps <= 0):
            row = int(np.argmax(steps <= 0)) + 1
            raise InputError(f"time does not increase in record {label!r} at its sample "
                             f"{row + 1} (counting from 1; separate records with a 'record' "
                             "column)", field=time_col or "t")
        phase: npt.NDArray[np.str_] | None = None
        if "phase" in group.columns:
            if group["phase"].isna().any():
                raise InputError(f"empty phase label in record {label!r}", field="phase")
            phase = _phase_labels(group["phase"])
        condition: dict[str, float] = {}
        if len(groups) == 1:
            condition.update({k: float(v) for k, v in header_condition.items()
                              if k in CONDITION_CHANNELS and isinstance(v, int | float)
                              and math.isfinite(float(v))})
        units = {columns_chan: columns_unit for columns_chan, columns_unit, _, _
                 in columns.values() if columns_chan != "t"}
        for chan in CONDITION_CHANNELS:
            if chan in values:
                v = values[chan]
                if float(np.ptp(v)) <= 1e-9 * max(1.0, float(np.max(np.abs(v)))):
                    condition[chan] = float(v[0])
                    if chan != "oil_temperature":
                        del values[chan]
                        del units[chan]
        records.append(SeriesRecord(label, t, values, units, phase, condition, meta, measured,
                                    start, notes))
    return records


def _not_numbers(column: pd.Series) -> str:
    """Why a column that is not numbers is refused: date-times (a logger's wall clock) are
    not a time column here, labels go to the record or phase column."""
    stamps = pd.to_datetime(column.astype(str), errors="coerce", format="mixed")
    if stamps.notna().all():  # "a column of labels?" was the hint (an analyst's pass)
        return ("the column holds date-times, which are not read as time: map it to "
                "['skip', '-'] and give the sample rate and the start (started_at), or add "
                "a 't [s]' column of seconds")
    return ("a value is not a number (a column of labels? map it to ['record', '-'] or "
            "['phase', '-'])")


#: temperatures a hydraulic rig's channels can read [°C]: beyond them the column's unit is
#: the other one (40 under ``[K]`` read −233 °C, and was refused later with two different
#: bounds, naming neither the column nor the unit; a modelling engineer's pass)
TEMPERATURE_RANGE_C = (-60.0, 250.0)


def _check_temperature(values: Arr, column: str, label: str) -> None:
    lo, hi = float(np.min(values)), float(np.max(values))
    if lo < TEMPERATURE_RANGE_C[0] or hi > TEMPERATURE_RANGE_C[1]:
        bad = lo if lo < TEMPERATURE_RANGE_C[0] else hi
        other = "°C under a [K] label" if bad < 0 else "K (or °F) under a [degC] label"
        raise InputError(
            f"record {label!r} reads {bad:.4g} °C, outside the {TEMPERATURE_RANGE_C[0]:g} to "
            f"{TEMPERATURE_RANGE_C[1]:g} °C a rig's temperature can have: is it in {other}?",
            field=column)


#: a logged spool command read as the phase it commands (paper 002 §3: N = +1 working,
#: N = −1 return)
_SPOOL_COMMAND = {1.0: "working", -1.0: "return"}


def _phase_labels(column: pd.Series) -> npt.NDArray[np.str_]:
    """The phase labels of a record: as written, or a numeric spool command N = ±1 as
    ``working``/``return`` (other numbers, e.g. 0 with the spool centred, stay as written)."""
    numbers = pd.to_numeric(column, errors="coerce")
    labels = column.astype(str).to_numpy().astype(np.str_)
    if numbers.notna().all():
        labels = np.array([_SPOOL_COMMAND.get(float(v), str(label))
                           for v, label in zip(numbers, labels, strict=True)], dtype=np.str_)
    return labels


def read_series(source: str | Path | bytes | pd.DataFrame, *, format: str | None = None,
                column_map: Mapping[str, ColumnEntry] | None = None,
                expected: Mapping[str, str] | None = None, required: Sequence[str] = (),
                measured: bool = True, sample_rate: float | None = None,
                started_at: datetime | None = None, name: str | None = None,
                max_bytes: int = MAX_DECOMPRESSED_BYTES) -> list[SeriesRecord]:
    """Read measured time series from a CSV or Parquet file (path or bytes) or a table.

    See the module docstring for the format and :func:`series_from_frame` for the options.
    ``format`` (``"csv"``/``"parquet"``) is taken from the file suffix or the bytes when
    not given; ``name`` names a record without a ``record`` column (default: the file's
    name without ``.gz``, ``upload`` for bytes).  A gzip-compressed file (``.gz``, as
    loggers and archives keep them) is read decompressed, up to ``max_bytes`` [byte].

    Raises
    ------
    InputError
        The file cannot be read, or a column is invalid (the error names it).
    """
    frame, meta, source_name = read_table(source, format, max_bytes)
    if frame.empty:
        raise InputError("the table has no rows", field="file")
    return series_from_frame(frame, name=name or source_name, column_map=column_map, expected=expected,
                             required=required, metadata=meta, measured=measured,
                             sample_rate=sample_rate, started_at=started_at)
