"""Numbers typed into the console's fields, as engineers type them.

A German or French engineer writes ``4,2`` for 4.2, and the decimal keypad that
``inputmode="decimal"`` opens on a phone or tablet in those locales has a comma and no
point; long numbers are written in groups (``1 500``).  The console's fields took neither
and answered "not a number" (a console pass, stop 52).  The HTTP API and the files keep
their own rules (JSON numbers; CSV files say their decimal mark by their separator).
"""

from __future__ import annotations

import re

from diagnostics.table_files import DECIMAL_COMMA
from sim.errors import InputError

__all__ = ["decimal_text", "form_number"]

#: spaces written between digit groups of three: space, no-break space, narrow no-break
#: space, thin space, and the apostrophe of Swiss usage (1'500); "2 1" is no group (it read
#: as 21: a verification pass)
_GROUP = re.compile(r"(?<=\d)[ \u00a0\u202f\u2009'](?=\d{3}(?!\d))")
#: a comma between digits with exactly three after it and a nonzero whole part: 1,500 is
#: 1.5 in Germany and 1500 in England
_AMBIGUOUS = re.compile(r"^[+-]?[1-9]\d{0,2},\d{3}$")


def decimal_text(text: str, *, field: str) -> str:
    """``text`` with a decimal comma as a point and digit-group spaces dropped: ``"4,2"`` →
    ``"4.2"``, ``"1 500"`` → ``"1500"``, ``"-0,5e-3"`` → ``"-0.5e-3"``; blank stays blank,
    and anything else is left for the caller's own check of a number.

    Raises
    ------
    InputError
        ``1,500`` and the like (a comma before exactly three digits): 1.5 or 1500 by the
        writer's country, so the field (``field``) is asked to say which.
    """
    stripped = _GROUP.sub("", text.strip())
    if not DECIMAL_COMMA.match(stripped):  # the CSV reader's own test of a decimal comma
        return stripped
    if _AMBIGUOUS.match(stripped):
        whole, part = stripped.split(",")
        raise InputError(f"{text.strip()!r} reads as {whole}.{part} with a decimal comma and as "
                         f"{whole}{part} with a thousands comma: write it with a point "
                         f"({whole}.{part}) or without the comma ({whole}{part})", field=field)
    return stripped.replace(",", ".")


def form_number(text: str, *, field: str) -> float:
    """The number typed into field ``field`` (:func:`decimal_text`), finite.

    Raises
    ------
    InputError
        Not a number, or not finite, naming ``field``.
    """
    cleaned = decimal_text(text, field=field)
    try:
        value = float(cleaned)
    except ValueError:
        raise InputError(f"not a number: {text.strip()!r} (write it as 4.2 or 4,2)",
                         field=field) from None
    if value != value or value in (float("inf"), float("-inf")):
        raise InputError(f"not a finite number: {text.strip()!r}", field=field)
    return value
