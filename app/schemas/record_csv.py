"""Measurement records from a CSV table: one record per row, dotted column names nest.

``condition.load_force`` becomes ``{"condition": {"load_force": ...}}``; empty cells are
left out (the reading was not taken); ``#`` lines are comments.  The rows are plain
dictionaries for :class:`~app.schemas.diagnose.MeasurementIn` to validate.  Used by the
console's upload and by ``hydrodiag diagnose-batch``.
"""

from __future__ import annotations

import io
from typing import Any

from sim.errors import InputError

__all__ = ["record_rows"]


def record_rows(content: bytes, *, field: str) -> list[dict[str, Any]]:
    """The rows of the CSV ``content`` as nested record dictionaries.

    Raises
    ------
    InputError
        Not a readable CSV (naming ``field``).
    """
    import pandas as pd

    try:
        frame = pd.read_csv(io.BytesIO(content), comment="#")
    except (ValueError, UnicodeDecodeError, pd.errors.ParserError) as exc:
        raise InputError(f"not a readable CSV: {exc}", field=field) from None
    rows = []
    for _, row in frame.iterrows():
        record: dict[str, Any] = {}
        for column, value in row.items():
            if pd.isna(value):
                continue
            target = record
            *parents, leaf = str(column).strip().split(".")
            for part in parents:
                target = target.setdefault(part, {})
            target[leaf] = value.item() if hasattr(value, "item") else value
        rows.append(record)
    return rows
