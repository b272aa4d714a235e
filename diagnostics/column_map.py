"""A column map (:mod:`diagnostics.timeseries`): raw column → ``(channel, unit)`` or
``(channel, unit, gain, offset)``, its entries checked.

A list of pairs is refused rather than read as a mapping (it raised "'list' object has no
attribute 'items'": a library user's pass): a column named twice in it would be chosen
without a word.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from sim.errors import InputError
from sim.numbers import field_number

__all__ = ["SKIP", "ColumnEntry", "column_entry", "read_column_map"]

#: the column map's channel name that leaves a column out
SKIP = "skip"
#: one column map entry: (channel, unit) or (channel, unit, gain, offset)
ColumnEntry = tuple[str, str] | tuple[str, str, float, float]


def column_entry(raw: str, entry: ColumnEntry) -> tuple[str, str, float, float]:
    """A column map entry as ``(channel, unit, gain, offset)`` (gain 1, offset 0 when not
    given).

    Raises
    ------
    InputError
        Not 2 or 4 items, a channel or unit that is no text, a gain that is 0 or not
        finite, an offset not finite (``raw``).
    """
    if isinstance(entry, str | bytes) or not isinstance(entry, Sequence) or not all(
            isinstance(x, str) for x in entry[:2]):
        raise InputError("a column map entry is [channel, unit] or [channel, unit, gain, "
                         f"offset], not {entry!r}"[:300], field=raw)
    if len(entry) == 2:
        return entry[0], entry[1], 1.0, 0.0
    if len(entry) == 4:
        gain = field_number(entry[2], raw, expected="a calibration gain")
        offset = field_number(entry[3], raw, expected="a calibration offset")
        if not (math.isfinite(gain) and gain != 0.0 and math.isfinite(offset)):
            raise InputError(f"the calibration of {raw!r} needs a finite, non-zero gain and a "
                             f"finite offset, got {entry[2]!r}, {entry[3]!r}", field=raw)
        return entry[0], entry[1], gain, offset
    raise InputError("a column map entry is [channel, unit] or [channel, unit, gain, offset]",
                     field=raw)


def read_column_map(column_map: object) -> dict[str, tuple[str, str, float, float]]:
    """Each entry of ``column_map`` (None: none) as :func:`column_entry` gives it.

    Raises
    ------
    InputError
        Not a mapping (``field="column_map"``), or an entry :func:`column_entry` refuses.
    """
    if column_map is None:
        return {}
    if not isinstance(column_map, Mapping):
        raise InputError(f"a column map is a mapping raw column → (channel, unit), e.g. "
                         f"{{'PS1': ('P_pump', 'bar')}} (dict(pairs) for a list of pairs), "
                         f"not a {type(column_map).__name__}", field="column_map")
    return {raw: column_entry(raw, entry) for raw, entry in column_map.items()}
