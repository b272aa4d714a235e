"""Times of the API: ISO 8601 with its zone only, the windows of queries, when a
measurement may have been taken, and one written form of a UTC time on every interface."""

from __future__ import annotations

import datetime as dt
import re
from datetime import datetime
from typing import Annotated, Any

from pydantic import AfterValidator, AwareDatetime, BeforeValidator, Field, TypeAdapter, ValidationError
from pydantic_core import PydanticCustomError

from sim.errors import InputError

__all__ = [
    "EARLIEST_MEASUREMENT",
    "FUTURE_ALLOWANCE_S",
    "IsoDatetime",
    "MeasurementTime",
    "SinceTime",
    "Timestamp",
    "UntilTime",
    "filter_time",
    "iso_only",
    "iso_utc",
    "measurement_time_problem",
    "utc_if_zoneless",
]


_ISO_DATE = re.compile(r"^\d{4}-\d{2}-\d{2}")


#: a time whose offset's "+" a URL's query string turned into a space
_SPACED_OFFSET = re.compile(r"T\d{2}:\d{2}(:\d{2}(\.\d+)?)? \d{2}(:?\d{2})?$")


def iso_only(value: Any) -> Any:
    """Before-validator of a time: a datetime or an ISO 8601 string, never a number.

    pydantic would read ``0.5`` (or ``"0.5"``) as seconds since 1970; the API documents
    ISO 8601 (``format: date-time``), so anything else is refused.
    """
    if isinstance(value, dt.datetime):
        return value
    if isinstance(value, str) and _SPACED_OFFSET.search(value):
        # a query string reads "+05:00" as " 05:00": "unexpected extra characters" said
        # nothing of it (a reliability engineer's pass)
        raise ValueError("the '+' of the zone offset arrived as a space: in a URL write it "
                         "%2B (…T14:00:00%2B05:00), or give the time in UTC with Z")
    if isinstance(value, str) and _ISO_DATE.match(value):
        return value
    raise ValueError("give the time as ISO 8601 with its zone, e.g. 2026-11-22T08:30:00Z")


#: A time with its zone, as ISO 8601 only (query parameters and body fields).
IsoDatetime = Annotated[AwareDatetime, BeforeValidator(iso_only)]

_DAY_ONLY = re.compile(r"^\d{4}-\d{2}-\d{2}$")
#: a date and a time of day without a zone, "2026-11-20 08:00" or "2026-11-20T08:00:00"
_ZONELESS = re.compile(r"^\d{4}-\d{2}-\d{2}[ T]\d{2}:\d{2}(:\d{2}(\.\d+)?)?$")


def utc_if_zoneless(text: str) -> str:
    """``text`` with ``Z`` where it is a date and a time of day without a zone, for the
    console's and the CLI's filters, whose labels say UTC ("2026-11-20 08:00" was refused
    there: a plant operator's pass); the HTTP queries keep asking for the zone."""
    stripped = text.strip()
    return stripped.replace(" ", "T") + "Z" if _ZONELESS.match(stripped) else text


def _day_start(value: Any) -> Any:
    """A date alone (``2026-05-16``) as the start of that day, UTC."""
    return f"{value}T00:00:00Z" if isinstance(value, str) and _DAY_ONLY.match(value) else value


def _day_end(value: Any) -> Any:
    """A date alone as the end of that day, UTC (a filter "until 2026-05-16" takes it in)."""
    return (f"{value}T23:59:59.999999Z" if isinstance(value, str) and _DAY_ONLY.match(value)
            else value)


#: The start of a time window of a query: ISO 8601 with its zone, or a date alone, read as
#: the start of that day in UTC (the console took a date, the API refused it: a planner)
SinceTime = Annotated[AwareDatetime, BeforeValidator(iso_only), BeforeValidator(_day_start)]
#: The end of a time window of a query: as :data:`SinceTime`, a date alone read as the end
#: of that day in UTC
UntilTime = Annotated[AwareDatetime, BeforeValidator(iso_only), BeforeValidator(_day_end)]

#: Earliest time a measurement may be stored with (digital records; a 1900 date is a
#: logger's unset clock) [UTC].
EARLIEST_MEASUREMENT = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
#: How far ahead of the service's clock a measurement time may lie (clock skew, a zone
#: written wrong by up to a day) [s].
FUTURE_ALLOWANCE_S = 86400.0


def measurement_time_problem(value: dt.datetime) -> str | None:
    """Why ``value`` cannot be when something was measured (None: it can): before
    :data:`EARLIEST_MEASUREMENT` or more than :data:`FUTURE_ALLOWANCE_S` ahead of now.  A
    record dated 2999 went to the top of the history and stretched every trend's axis to
    4e5 days."""
    now = dt.datetime.now(dt.UTC)
    latest = now + dt.timedelta(seconds=FUTURE_ALLOWANCE_S)
    if value < EARLIEST_MEASUREMENT:
        return (f"{value.isoformat()} is before {EARLIEST_MEASUREMENT.date()}: not a time a "
                "measurement was taken (a logger's unset clock?)")
    if value > latest:
        # the clock itself, not the clock plus the allowance it named as the clock (an
        # operator's pass)
        return (f"{value.isoformat()} is in the future (more than a day after the service's "
                f"clock, {now.replace(microsecond=0).isoformat()})")
    return None


def _measured(value: dt.datetime) -> dt.datetime:
    problem = measurement_time_problem(value)
    if problem is not None:  # the sentence as it is, without pydantic's "Value error, "
        raise PydanticCustomError("measurement_time", "{problem}", {"problem": problem})
    return value


#: When something was measured: ISO 8601 with zone, from 1970 to a day ahead of now.
MeasurementTime = Annotated[AwareDatetime, BeforeValidator(iso_only), AfterValidator(_measured)]

Timestamp = Annotated[
    datetime,
    Field(
        description="Time, ISO 8601 with zone [UTC]",
        examples=["2026-11-22T08:30:00Z"],
    ),
]



def iso_utc(moment: datetime) -> str:
    """``moment`` in ISO 8601 as pydantic writes an aware time (UTC as ``Z``): one form on
    every interface (the CLI's CSV and JSON Lines and the 409 messages wrote ``+00:00``
    where HTTP wrote ``Z``, and a join on the text failed: a fleet integrator's pass)."""
    text = moment.isoformat()
    return text[:-6] + "Z" if text.endswith("+00:00") else text


def filter_time(text: str | None, kind: Any, field: str) -> datetime | None:
    """A window's end typed by a person (the console's filters, the CLI's ``--since`` and
    ``--until``), read as the HTTP queries read ``since``/``until`` (``kind``:
    :data:`SinceTime` or :data:`UntilTime`: ISO 8601 with its zone, or a date alone, the
    whole day), and a date and time without a zone as UTC, as those labels say; blank for
    none.

    Raises
    ------
    InputError
        Naming ``field``, with the forms it takes.
    """
    if text is None or not text.strip():
        return None
    try:
        value: datetime = TypeAdapter(kind).validate_python(utc_if_zoneless(text))
    except ValidationError as exc:
        raise InputError(f"{text!r} is not a time ({exc.errors()[0]['msg']}): give it as "
                         "2026-01-01 08:00 (UTC), ISO 8601 with its zone, e.g. "
                         "2026-01-01T08:00:00+02:00, or a date alone, 2026-01-01 (the whole "
                         "day, UTC)", field=field) from None
    return value
