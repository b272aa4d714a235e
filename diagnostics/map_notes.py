"""What a column map names that an imported file lacks.

A column map entry whose column is not in the file is left out of the import, so that one
map can serve a logger's files with and without a channel; but a map written for the file
at hand and a column the file lacks (a misspelt key, ``Durchfluß`` for ``Durchfluss``, or a
channel the logger did not record) stored records that no reader could use, with a note
blaming the map's targets (an analyst's pass).  The note here names the entry.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from diagnostics.timeseries import SKIP, ColumnEntry, SeriesRecord

__all__ = ["unmatched_map_notes"]

#: map targets that are not channels of a record
_NOT_CHANNELS = ("record", "phase", "t", SKIP)


def unmatched_map_notes(column_map: Mapping[str, ColumnEntry] | None,
                        records: Sequence[SeriesRecord]) -> list[str]:
    """One note per column map entry whose channel no record of the import has (neither as
    a channel nor as a constant condition): the file lacks the column the entry names."""
    have = {c for r in records for c in (*r.channels, *r.condition)}
    notes = []
    for raw, entry in (column_map or {}).items():
        channel = entry[0]
        if channel in _NOT_CHANNELS or channel in have:
            continue
        notes.append(f"the column map names {raw!r} (as {channel}), which the file does not "
                     f"have: no {channel} was stored (a misspelt column name in the map, or a "
                     "file without that channel?)")
    return notes
