"""A measured cycle as the record ``POST /diagnose`` takes.

Used by ``GET /series/{id}/record`` and ``hydrodiag diagnose --series`` / ``hydrodiag
diagnose CYCLE.csv``: a cycle (a stored series, or a file read by the one import path
:func:`diagnostics.timeseries.read_series`) is read phase by phase
(:func:`diagnostics.cycle_readings.cycle_readings`, with the stroke of the rig document it
will be diagnosed against) and written as a ``record`` body of ``/diagnose``: the same
validation, the same diagnosis, the same history as readings typed in by hand.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session

from app.schemas.diagnose import MEASURED_FIELDS
from app.schemas.times import iso_utc
from app.services.rig_cache import ResolvedRig, RigCache
from app.services.rig_channels import rig_channels
from app.services.series import as_record, get_series
from diagnostics.cycle_readings import CycleReadings, cycle_readings
from diagnostics.map_notes import unmatched_map_notes
from diagnostics.sampling import sampling_notes
from diagnostics.timeseries import ColumnEntry, SeriesRecord, read_series

__all__ = ["READING_UNITS", "CycleRecord", "cycle_record", "file_cycle_records", "record_body",
           "stored_cycle_record"]

#: unit of each reading of a record [SI], as the record's schema states it
READING_UNITS: dict[str, str] = {name: unit for name, (unit, _) in MEASURED_FIELDS.items()}


@dataclass(frozen=True)
class CycleRecord:
    """A cycle read as a record: the rig it was read against, the readings and the body."""

    rig: ResolvedRig
    readings: CycleReadings
    body: dict[str, Any]


def record_body(readings: CycleReadings, rig_id: int, rig_version: int | None,
                measured_at: datetime | None = None, series_id: int | None = None
                ) -> dict[str, Any]:
    """The ``record`` of a ``/diagnose`` body: rig, the cycle's clock time when known, the
    stored series it was read from (if any), condition and readings [SI], each of its
    default instrument class (checked by building the measurement record)."""
    readings.record(str(rig_id))  # an impossible reading is a 422 here, naming its field
    body: dict[str, Any] = {"rig_id": rig_id}
    if rig_version is not None:
        body["rig_version"] = rig_version
    if measured_at is not None:
        body["measured_at"] = iso_utc(measured_at)
    if series_id is not None:
        body["series_id"] = series_id
    body["condition"] = dict(readings.condition)
    body.update(readings.readings)
    return body


def cycle_record(series: SeriesRecord, rig: ResolvedRig,
                 condition: Mapping[str, float] | None = None,
                 series_id: int | None = None) -> CycleRecord:
    """Read ``series`` against ``rig`` (its stroke), the ``condition`` given overriding the
    series'; the body names the rig version read against, so that it is diagnosed there,
    the clock time of the cycle's first sample when the series has one, and the stored
    series ``series_id`` it came from."""
    rig.rig.require_cycle("reading a cycle as a record")
    readings = cycle_readings(series, rig.rig.base["cylinder.stroke"], condition,
                              model_channels=list(rig.rig.channels()))
    body = record_body(readings, rig.rig_id, rig.version, series.measured_at, series_id)
    return CycleRecord(rig, readings, body)


def stored_cycle_record(session: Session, rigs: RigCache, series_id: int, *,
                        rig_version: int | None = None,
                        condition: Mapping[str, float] | None = None) -> CycleRecord:
    """The stored cycle ``series_id`` read against its rig (``rig_version``, else the
    latest).

    Raises
    ------
    NotFoundError
        No series ``series_id``, or its rig has no such version.
    CircuitError
        The rig has no cylinder cycle.
    InputError
        The series is not a readable cycle (:func:`diagnostics.cycle_readings.cycle_readings`)
        or gives an impossible reading.
    """
    row = get_series(session, series_id)
    rig = rigs.get(session, row.rig_id, rig_version)
    return cycle_record(as_record(row), rig, condition, row.id)


def file_cycle_records(session: Session, rigs: RigCache, path: Path, rig_id: int, *,
                       rig_version: int | None = None,
                       condition: Mapping[str, float] | None = None,
                       column_map: Mapping[str, ColumnEntry] | None = None,
                       sample_rate: float | None = None,
                       started_at: datetime | None = None
                       ) -> tuple[list[CycleRecord], list[str]]:
    """Every cycle of a CSV or Parquet file (its ``record`` column separates them) read
    against rig ``rig_id`` (``rig_version``, else the latest), through ``column_map``,
    ``sample_rate`` and ``started_at`` as :func:`diagnostics.timeseries.read_series` takes
    them, with the notes the import of the file would give (the channels, the clock, the
    rate); errors name ``--rig`` and the file's column."""
    rig = rigs.get(session, rig_id, rig_version, rig_field="--rig", version_field="--version")
    # the checks of the import of the same file and map (a CLI pass: a misspelt channel
    # dropped without a word, bar on a flow column converted, ms read as s, a rate that
    # contradicts the time column, all silent here and said there)
    channels = rig_channels(session, rig_id)
    series = read_series(path, column_map=column_map, sample_rate=sample_rate,
                         started_at=started_at, expected=channels.units)
    notes = (unmatched_map_notes(column_map, series) + channels.read_notes(series)
             + channels.time_notes(series) + sampling_notes(series, sample_rate))
    return [cycle_record(s, rig, condition) for s in series], notes
