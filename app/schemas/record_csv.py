"""Measurement records from a CSV table: one record per row, dotted column names nest.

``condition.load_force`` becomes ``{"condition": {"load_force": ...}}``; empty cells are
left out (the reading was not taken); ``#`` lines are comments.  The rows are plain
dictionaries for :class:`~app.schemas.diagnose.MeasurementIn` to validate.  Used by the
console's upload and by ``hydrodiag diagnose-batch``.

A row is read as written or refused naming its line: a row with fewer cells than the
header (a cut line would have left its last readings "not taken"), more cells that are
not empty, or a cell that writes a number as ``nan`` or ``inf`` (only an empty cell
means "not taken", as ``null`` does in JSON).  Trailing empty cells, as spreadsheets
write them after the last column, are allowed.
"""

from __future__ import annotations

import csv
import math
import re
from typing import Any, Literal, overload

from diagnostics.table_files import DECIMAL_COMMA, stated_dialect
from sim.errors import InputError

__all__ = ["record_rows"]

_INTEGER = re.compile(r"^[+-]?[0-9]+$")


def _value(cell: str, *, line: int, column: str, field: str, decimal: str = ".") -> Any:
    """A cell as JSON would carry it: an integer, a finite number or text (``decimal``:
    the file's decimal mark)."""
    text = cell.strip()
    if decimal == "," and DECIMAL_COMMA.match(text):
        text = text.replace(",", ".")
    if _INTEGER.match(text):
        return int(text)
    try:
        number = float(text)
    except ValueError:
        return text  # a time, a rig name: validated by the record's schema
    if not math.isfinite(number):
        raise InputError(f"line {line}: {column} is {text!r}; leave a reading out with an "
                         "empty cell", field=field)
    return number


@overload
def record_rows(content: bytes, *, field: str, lines: list[int] | None = None,
                per_row: Literal[False] = False) -> list[dict[str, Any]]: ...


@overload
def record_rows(content: bytes, *, field: str, lines: list[int] | None = None,
                per_row: Literal[True]) -> list[dict[str, Any] | InputError]: ...


def record_rows(content: bytes, *, field: str, lines: list[int] | None = None,
                per_row: bool = False) -> list[dict[str, Any]] | list[dict[str, Any] | InputError]:
    """The rows of the CSV ``content`` as nested record dictionaries; ``lines``, where
    given, gets the file's line of each row (to name it in a record's error).  With
    ``per_row`` a row refused for its cells (below) is its :class:`InputError` in its place
    instead of an error for the whole file (``diagnose-batch --skip-invalid`` diagnoses
    the others: a ``nan`` cell refused the whole batch, a CLI pass).

    Raises
    ------
    InputError
        Not UTF-8 or not a CSV, a row whose cells do not match the header, a ``nan`` or
        ``inf`` cell (naming ``field`` and the line).
    """
    try:
        text = content.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError("not a readable CSV: the file is not UTF-8 text", field=field
                         ) from None
    kept = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
            if line.strip() and not line.lstrip().startswith("#")]
    if not kept:
        return []
    # the dialects the series import reads: a semicolon file of a European spreadsheet was
    # read as one column named "rig_id;measured_at;condition" (a maintenance planner's pass)
    stated, sep, decimal = stated_dialect([line for _, line in kept[:7]])
    kept = kept[stated:]
    reader = csv.reader((line + "\n" for _, line in kept), strict=True, delimiter=sep)
    table: list[tuple[int, list[str]]] = []  # (the file's line a row ends on, its cells)
    try:
        for cells in reader:  # a quoted cell may span lines: count rows by the reader
            table.append((kept[reader.line_num - 1][0], cells))
    except csv.Error as exc:
        raise InputError(f"not a readable CSV: {exc}", field=field) from None
    header = [name.strip() for name in table[0][1]]
    while header and not header[-1]:  # a spreadsheet's trailing separator
        header.pop()
    if not header or any(not name for name in header):
        raise InputError(f"line {table[0][0]}: every column needs a name", field=field)
    rows: list[dict[str, Any] | InputError] = []
    for number, cells in table[1:]:
        try:
            rows.append(_record(header, cells, number, field, decimal))
        except InputError as exc:
            if not per_row:
                raise
            rows.append(exc)
        if lines is not None:
            lines.append(number)
    return rows


def _record(header: list[str], cells: list[str], number: int, field: str, decimal: str
            ) -> dict[str, Any]:
    """The nested record of one row (file line ``number``) under ``header``."""
    if len(cells) < len(header) or any(c.strip() for c in cells[len(header):]):
        raise InputError(f"line {number} has {len(cells)} cells for the header's "
                         f"{len(header)} columns", field=field)
    record: dict[str, Any] = {}
    for column, cell in zip(header, cells, strict=False):
        if not cell.strip():
            continue
        target = record
        *parents, leaf = column.split(".")
        for part in parents:
            target = target.setdefault(part, {})
        target[leaf] = _value(cell, line=number, column=column, field=field, decimal=decimal)
    return record
