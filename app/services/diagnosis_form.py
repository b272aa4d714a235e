"""A validated ``POST /diagnose`` in plain data: validated once, never again (issue 9).

The server process validates the request body with pydantic (:class:`DiagnoseRequest`:
every 422 names its field) and hands the diagnosis process its *form*: the same request as
named tuples of numbers and strings (:class:`RequestForm`), which pickle in a few
microseconds and need no validation on the other side.  There :func:`measurement_record`
builds the diagnostics record and :func:`stored_document` the document the history keeps,
equal to what :func:`app.services.measurements.to_record` and
:func:`~app.services.measurements.stored_record` make of the validated model (the console
and the command line use those; ``tests/app/test_diagnosis_form.py`` holds them equal).

A reading is ``(value, u, bound)`` [unit of its field]: ``u`` its standard uncertainty,
``bound`` its instrument bound (rectangular, u = bound/√3), ``None`` where not given (a bare
number: the field's default instrument class).
"""

from __future__ import annotations

from collections.abc import Mapping
from datetime import datetime
from typing import Any, Literal, NamedTuple

from app.schemas.diagnose import MEASURED_FIELDS, ConditionIn, DiagnoseRequest, MeasurementIn
from app.schemas.times import iso_utc
from app.services.common import prefixed
from diagnostics.measurement import MeasurementRecord, OperatingCondition
from diagnostics.quantity import Quantity
from sim.errors import MeasurementError

__all__ = ["CONDITION_FIELDS", "ReadingForm", "RecordForm", "RequestForm", "measurement_record",
           "record_form", "request_form", "stored_document"]

#: Fields of a record's operating condition, in the schema's order.
CONDITION_FIELDS = tuple(ConditionIn.model_fields)

#: Measured fields of a record, in the schema's order.
_MEASURED = tuple(MEASURED_FIELDS)

#: A reading: value, standard uncertainty or ``None``, instrument bound or ``None``
#: [unit of its field].
ReadingForm = tuple[float, float | None, float | None]


class RecordForm(NamedTuple):
    """One validated record.

    Attributes
    ----------
    path
        Its path in the request (``record``, ``records[2]``).
    rig_id, rig_version
        The rig, and the version of its document (``None``: the latest).
    measured_at
        When the readings were taken [UTC]; ``None``: the time of the request.
    series_id
        The stored series the readings were read from, or ``None``.
    condition, readings
        The operating condition's and the measured readings given, by field name in the
        schema's order (:data:`ReadingForm` each).
    calibration_share
        The share of each stated variance that is a calibration error shared by a joint
        visit's records [-], or ``None`` where not given (0).
    """

    path: str
    rig_id: int
    rig_version: int | None
    measured_at: datetime | None
    series_id: int | None
    condition: dict[str, ReadingForm]
    readings: dict[str, ReadingForm]
    calibration_share: float | None = None


class RequestForm(NamedTuple):
    """One validated request: how its records are diagnosed, and the records.

    Attributes
    ----------
    mode
        ``single`` (``record``), ``each`` or ``joint`` (``records``).
    store, compact
        The request's options.
    records
        The records in request order.
    """

    mode: Literal["single", "each", "joint"]
    store: bool
    compact: bool
    records: list[RecordForm]


def _readings(model: MeasurementIn | ConditionIn, names: tuple[str, ...]
              ) -> dict[str, ReadingForm]:
    out: dict[str, ReadingForm] = {}
    for name in names:
        item = getattr(model, name)
        if item is not None:
            out[name] = (item.value, item.u, item.bound)
    return out


def record_form(data: MeasurementIn, path: str) -> RecordForm:
    """The form of one validated record at ``path`` in its request."""
    return RecordForm(path, data.rig_id, data.rig_version, data.measured_at, data.series_id,
                      _readings(data.condition, CONDITION_FIELDS), _readings(data, _MEASURED),
                      data.calibration_share)


def request_form(request: DiagnoseRequest) -> RequestForm:
    """The form of a validated request.

    Raises
    ------
    InputError
        Both or neither of ``record`` and ``records``, or ``joint`` with one record
        (:meth:`DiagnoseRequest.items`).
    """
    items = request.items()
    mode: Literal["single", "each", "joint"] = (
        "single" if request.record is not None else "joint" if request.joint else "each")
    return RequestForm(mode, request.store, request.compact,
                       [record_form(record, path) for path, record in items])


def _quantity(reading: ReadingForm) -> float | Quantity:
    """A bare value (default instrument class) or a :class:`Quantity` with its uncertainty."""
    value, u, bound = reading
    if u is not None:
        return Quantity(value, u, "normal")
    if bound is not None:
        return Quantity.from_bound(value, bound)
    return value


def measurement_record(form: RecordForm, *, rig_name: str, measured_at: datetime
                       ) -> MeasurementRecord:
    """The diagnostics record of ``form``.

    Parameters
    ----------
    form
        The record.
    rig_name
        Name of the rig the record names.
    measured_at
        Time of the record (the request's when it gave none) [UTC].

    Raises
    ------
    MeasurementError
        The record is invalid or self-contradictory; ``field`` is its path in the request.
    """
    try:
        condition = OperatingCondition.from_readings(
            {name: _quantity(r) for name, r in form.condition.items()})
        return MeasurementRecord.from_readings(
            str(form.rig_id), condition,
            {name: _quantity(r) for name, r in form.readings.items()},
            rig_name=rig_name, taken_at=measured_at,
            calibration_share=form.calibration_share or 0.0)
    except MeasurementError as exc:
        raise MeasurementError(exc.message, field=prefixed(form.path, exc.field)) from None


def _reading_document(reading: ReadingForm) -> dict[str, float]:
    value, u, bound = reading
    document = {"value": value}
    if u is not None:
        document["u"] = u
    if bound is not None:
        document["bound"] = bound
    return document


def stored_document(form: RecordForm, measured_at: datetime) -> Mapping[str, Any]:
    """The record as the history keeps it: as given (the fields given, in the schema's
    order, readings as ``{value, u?, bound?}``), JSON-ready, its time filled in."""
    document: dict[str, Any] = {"rig_id": form.rig_id}
    if form.rig_version is not None:
        document["rig_version"] = form.rig_version
    if form.measured_at is not None:
        document["measured_at"] = None  # keeps its place; filled in below
    if form.series_id is not None:
        document["series_id"] = form.series_id
    document["condition"] = {name: _reading_document(r) for name, r in form.condition.items()}
    for name, reading in form.readings.items():
        document[name] = _reading_document(reading)
    if form.calibration_share is not None:
        document["calibration_share"] = form.calibration_share
    document["measured_at"] = iso_utc(measured_at)
    return document
