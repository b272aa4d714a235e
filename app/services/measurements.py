"""Measurement records of the API → :class:`diagnostics.measurement.MeasurementRecord`.

The API uses the record's own field names, so an error that ``diagnostics`` raises for
``flow_C.u`` or ``condition.oil_temperature`` only needs the record's path in the request
put in front (``records[2].flow_C.u``).
"""

from __future__ import annotations

from collections.abc import Mapping
from datetime import datetime
from typing import Any

from app.schemas.diagnose import MEASURED_FIELDS, ConditionIn, MeasurementIn, ReadingIn
from app.schemas.times import iso_utc
from app.services.common import prefixed
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.quantity import Quantity
from sim.errors import MeasurementError

__all__ = ["stored_record", "to_record"]

_CONDITION_FIELDS = tuple(ConditionIn.model_fields)


def _reading(item: ReadingIn) -> float | Quantity:
    """A bare value (default instrument class) or a :class:`Quantity` with its uncertainty."""
    if item.u is not None:
        return Quantity(item.value, item.u, "normal")
    if item.bound is not None:
        return Quantity.from_bound(item.value, item.bound)
    return item.value


def _readings(model: MeasurementIn | ConditionIn, names: tuple[str, ...]
              ) -> dict[str, float | Quantity]:
    out: dict[str, float | Quantity] = {}
    for name in names:
        item = getattr(model, name)
        if item is not None:
            out[name] = _reading(item)
    return out


def to_record(data: MeasurementIn, *, path: str, rig_name: str,
              measured_at: datetime) -> MeasurementRecord:
    """Build the diagnostics record of ``data``.

    Parameters
    ----------
    data
        The record as received.
    path
        Its path in the request (``"record"``, ``"records[2]"``), put in front of the field
        of any error.
    rig_name
        Name of the rig the record names.
    measured_at
        Time of the record (the request's when it gave none).

    Raises
    ------
    MeasurementError
        The record is invalid or self-contradictory; ``field`` is its path in the request.
    """
    try:
        condition = OperatingCondition.from_readings(_readings(data.condition,
                                                               _CONDITION_FIELDS))
        return MeasurementRecord.from_readings(
            str(data.rig_id), condition, _readings(data, tuple(MEASURED_FIELDS)),
            rig_name=rig_name, taken_at=measured_at,
            calibration_share=data.calibration_share or 0.0,
        )
    except MeasurementError as exc:
        raise MeasurementError(exc.message, field=prefixed(path, exc.field)) from None


def stored_record(data: MeasurementIn, measured_at: datetime) -> Mapping[str, Any]:
    """The record as kept in the history: as given, JSON-ready, with its time filled in."""
    document = data.model_dump(mode="json", exclude_none=True)
    document["measured_at"] = iso_utc(measured_at)
    return document
