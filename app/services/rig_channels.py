"""The channels of a rig's model an import is checked against: their SI units, the pump's
delivery and the relief setting a plateau table is read with, the limits of a piston's speed
(issue 12); and the file's column a channel came from, for the 422 that names it."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from sqlalchemy.orm import Session

from app.db.models import MeasuredSeries
from app.services.plateau_channels import (
    PLATEAU_CHANNELS,
    check_plateau_channels,
    plateau_notes,
    plateau_scale_notes,
)
from app.services.rigs import get_rig, has_cycle, latest_version
from diagnostics.channel_names import unknown_channel_note, unknown_channels
from diagnostics.consistency import RigLimits
from diagnostics.cycle_readings import READ_CHANNELS, unread_channel_note
from diagnostics.discrepancy.records import import_notes
from diagnostics.observations import rig_limits
from diagnostics.time_scale import coarse_notes, time_scale_notes
from diagnostics.timeseries import ColumnEntry, SeriesRecord
from sim.rigs import load_rig

__all__ = ["RigChannels", "column_of", "rig_channels"]

def column_of(channel: str | None, column_map: Mapping[str, ColumnEntry] | None) -> str | None:
    """The file's column that ``column_map`` maps to ``channel`` (the channel itself when
    none does): a unit slip named ``file.q_work`` where the file's column is
    ``Durchfluss`` (a real-data analyst's pass)."""
    for raw, entry in (column_map or {}).items():
        if entry[0] == channel:
            return raw
    return channel


@dataclass(frozen=True)
class RigChannels:
    """The channels of a rig's model (its latest version) and their SI units, and whether
    its circuit has the working/return cycle whose readings use them."""

    units: dict[str, str]
    cycle: bool
    #: the pump's geometric delivery ω·Vp at its stated speed [m³/s]; None without a pump
    delivery: float | None = None
    #: the relief valve's setting [Pa]; None without one
    relief: float | None = None
    #: what bounds the piston's speed (pump, chambers, stroke); None without a cycle
    limits: RigLimits | None = None

    #: the rig's parameter values (the unit checks of a cycle); None without a cycle
    values: dict[str, float] | None = None

    def check_plateaus(self, records: Sequence[SeriesRecord]) -> None:
        """On a rig without a cycle, refuse the unit slips its plateau channels reveal
        (:func:`~app.services.plateau_channels.check_plateau_channels`): the HTTP import
        and the CLI's alike (the CLI stored bar under [Pa])."""
        if not self.cycle:
            check_plateau_channels(records, self.delivery, self.relief)

    def time_notes(self, records: Sequence[SeriesRecord]) -> list[str]:
        """Records whose piston moves faster than the pump can drive it, or ≥ 30× slower:
        a wrong sample rate or time unit (:func:`diagnostics.time_scale.time_scale_notes`);
        records too short or too coarse to hold a stroke (:func:`~diagnostics.time_scale.
        coarse_notes`); channels their own values contradict (a unit slip, a flipped sign:
        :func:`diagnostics.discrepancy.records.import_notes`)."""
        units = [] if self.values is None else import_notes(records, self.values)
        plateaus = [] if self.cycle else plateau_scale_notes(records, self.delivery,
                                                             self.relief)
        return (time_scale_notes(records, self.limits) + coarse_notes(records, self.limits)
                + units + plateaus)

    def notes(self, rows: Sequence[MeasuredSeries]) -> list[str]:
        """What an import stored for a rig with a cycle that neither its model nor a cycle's
        readings know (a misspelt name in a column map, ``P9`` for ``P1``): stored as
        given, but nothing compares with it.  A rig without a cycle (the ZeMA rig) is read
        by its plateau channels (:data:`PLATEAU_CHANNELS`: :mod:`diagnostics.real.profile`),
        not by its model's outputs: the note names those it lacks."""
        if not self.cycle:
            return plateau_notes(rows)
        return self._cycle_notes([(r.record, r.units, r.condition) for r in rows])

    def read_notes(self, records: Sequence[SeriesRecord]) -> list[str]:
        """:meth:`notes` of records read, not stored (``hydrodiag diagnose FILE``, which
        dropped a misspelt channel without a word where the import said so: a CLI pass):
        the note each cycle's readings carry (:func:`diagnostics.cycle_readings.
        unread_channel_note`), once for the file; none for a rig without a cycle, which no
        cycle is read against."""
        if not self.cycle:
            return []
        note = unread_channel_note({c for r in records for c in r.channels}, list(self.units))
        return [] if note is None else [note]

    def _cycle_notes(self, records: Sequence[tuple[str, Mapping[str, str],
                                                   Mapping[str, Any] | None]]) -> list[str]:
        """The notes of :meth:`notes` for a rig with a cycle, of stored records' (name,
        units, condition)."""
        notes = []
        # the library's rule and note (diagnostics.channel_names), with its "did you mean"
        unknown = unknown_channels((c for _, units, _ in records for c in units),
                                   (*self.units, *READ_CHANNELS))
        if unknown:
            notes.append(unknown_channel_note(
                unknown, list(self.units),
                "stored as given, but no comparison or diagnosis reads them; a misspelt name "
                "is imported again with the column map corrected", also=READ_CHANNELS))
        for key, column in (("load", "load [N]"), ("oil_temperature", "oil_temperature [degC]")):
            # stored, then refused by every reader (a modelling engineer's pass): said now
            silent = [name for name, units, condition in records
                      if key not in (condition or {}) and key not in units]
            if silent:
                shown = ", ".join(repr(n) for n in silent[:3]) + (" …" if len(silent) > 3
                                                                   else "")
                notes.append(f"record(s) {shown} state no {key.replace('_', ' ')}: the "
                             "discrepancy workflow refuses them and GET /series/{id}/record "
                             f"needs it in its query; a constant '{column}' column states it")
        return notes


def rig_channels(session: Session, rig_id: int) -> RigChannels:
    """Rig ``rig_id``'s channels (its latest version): a channel of an import with one of
    these names must be of that dimension (a pressure in L/min was stored, and the
    workflow then read P1 985,787,553,649 σ off) — for a rig without a cycle its plateau
    channels too (:data:`PLATEAU_CHANNELS`)."""
    version = latest_version(session, get_rig(session, rig_id, field="rig_id"))
    cycle = has_cycle(version)
    rig = load_rig(version.document)
    units = rig.channels()
    base = rig.base
    delivery = (base["pump.speed"] * base["pump.Vp"] if "pump.speed" in base
                and "pump.Vp" in base else None)
    return RigChannels(units if cycle else units | PLATEAU_CHANNELS, cycle, delivery,
                       base.get("relief.Pset"), rig_limits(rig) if cycle else None,
                       dict(rig.values()) if cycle else None)
