"""Shapes shared by every resource: the strict request base, bounded ids, error body,
pages of a list, timestamps."""

from __future__ import annotations

import datetime as dt
import difflib
import re
import types
import typing
from collections.abc import Callable, Mapping
from datetime import datetime
from typing import Annotated, Any, ClassVar, Generic, TypeVar

from pydantic import (
    AfterValidator,
    AwareDatetime,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    TypeAdapter,
    ValidationError,
    model_validator,
)
from pydantic_core import PydanticCustomError

from sim.errors import InputError

__all__ = [
    "EARLIEST_MEASUREMENT",
    "ERROR_RESPONSES",
    "FUTURE_ALLOWANCE_S",
    "MAX_ID",
    "MAX_OFFSET",
    "ErrorBody",
    "ErrorDetail",
    "FiniteFloat",
    "IdInt",
    "IsoDatetime",
    "MeasurementTime",
    "Page",
    "PublicModel",
    "RequestModel",
    "SinceTime",
    "Timestamp",
    "UntilTime",
    "UploadForm",
    "error_doc",
    "filter_time",
    "iso_utc",
    "measurement_time_problem",
    "not_nullable",
    "reject_null",
    "utc_if_zoneless",
]

T = TypeVar("T")

#: Largest identifier the store can hold: a 32-bit signed integer column (PostgreSQL
#: ``integer``; SQLite's 64-bit integers hold it too).  Ids past it are a 422, never a
#: database overflow.
MAX_ID = 2**31 - 1

#: Largest ``offset`` of a page [-]: any stored list is far shorter.
MAX_OFFSET = 2**31 - 1

#: An identifier: a positive integer the store can hold.
IdInt = Annotated[int, Field(ge=1, le=MAX_ID)]

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


def _json_type_problem(annotation: Any, value: Any) -> str | None:
    """Why ``value`` (decoded JSON) is not of the JSON type ``annotation`` documents.

    pydantic's lax mode turns ``true`` into 1, ``"1.5"`` into 1.5 and ``0.5`` into a date;
    the OpenAPI document says integer, number, date-time, so such values are refused.
    Only the JSON kinds are compared (booleans, numbers, strings; lists and maps item by
    item); ranges and formats stay pydantic's.
    """
    return _checker(annotation)(value)


#: The check of each annotation met, built once (:func:`_checker`), with the annotation
#: kept alive beside it (the key is its ``id``).
_CHECKERS: dict[int, tuple[Any, Callable[[Any], str | None]]] = {}


def _checker(annotation: Any) -> Callable[[Any], str | None]:
    """:func:`_json_type_problem` for ``annotation``, its type inspected once: the check
    runs for every field of every request model on every request (issue 9)."""
    found = _CHECKERS.get(id(annotation))
    if found is None or found[0] is not annotation:
        found = (annotation, _build_checker(annotation))
        _CHECKERS[id(annotation)] = found
    return found[1]


def _no_problem(value: Any) -> str | None:
    return None


def _build_checker(annotation: Any) -> Callable[[Any], str | None]:
    origin = typing.get_origin(annotation)
    if origin is Annotated:
        return _checker(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        options = [_checker(a) for a in typing.get_args(annotation) if a is not type(None)]

        def union(value: Any) -> str | None:
            if value is None:
                return None
            problems = [check(value) for check in options]
            return None if any(p is None for p in problems) else problems[0]
        return union
    if origin in (list, tuple, set, frozenset):
        args = typing.get_args(annotation)
        item_check = _checker(args[0]) if args else _no_problem

        def array(value: Any) -> str | None:
            if not isinstance(value, list):
                return f"must be a JSON array, not {type(value).__name__}"
            for item in value:
                problem = item_check(item)
                if problem:
                    return problem
            return None
        return array
    if origin is dict:
        args = typing.get_args(annotation)
        value_check = _checker(args[1]) if len(args) == 2 else _no_problem

        def mapping(value: Any) -> str | None:
            if not isinstance(value, dict):
                return f"must be a JSON object, not {type(value).__name__}"
            for item in value.values():
                problem = value_check(item)
                if problem:
                    return problem
            return None
        return mapping
    if annotation in (int, float):

        def number(value: Any) -> str | None:
            if isinstance(value, bool) or not isinstance(value, int | float):
                return f"must be a JSON number, not {type(value).__name__}"
            return None  # a fraction for an integer: pydantic's own message
        return number
    if annotation is bool:
        def boolean(value: Any) -> str | None:
            if not isinstance(value, bool):
                return f"must be true or false, not {type(value).__name__}"
            return None
        return boolean
    if annotation is str:
        def string(value: Any) -> str | None:
            if not isinstance(value, str):
                return f"must be a JSON string, not {type(value).__name__}"
            return None
        return string
    if annotation is dt.datetime:
        def moment(value: Any) -> str | None:
            try:
                iso_only(value)
            except ValueError as exc:
                return str(exc)
            return None
        return moment
    return _no_problem

#: A float that must be finite (no NaN, no infinity).
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]

Timestamp = Annotated[
    datetime,
    Field(
        description="Time, ISO 8601 with zone [UTC]",
        examples=["2026-11-22T08:30:00Z"],
    ),
]


def reject_null(value: T | None) -> T:
    """Validator for update models: a field may be left out, but not set to null."""
    if value is None:
        raise ValueError("may be left out, but not set to null")
    return value


def _unknown_field_message(unknown: list[str], known: list[str],
                           synonyms: Mapping[str, str] | None = None) -> str:
    parts = []
    for name in unknown[:10]:
        by_case = {k.lower(): k for k in known}
        # a case slip ("flow_b" for "flow_B") first: plain ratios would tie it with "flow_C"
        close = [by_case[c] for c in difflib.get_close_matches(name.lower(), list(by_case),
                                                               n=1, cutoff=0.6)]
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        if synonyms and name in synonyms:  # another operation's name for the same quantity
            hint = f" (here it is {synonyms[name]!r})"
        parts.append(f"{name[:100]!r}{hint}")
    if len(unknown) > 10:
        parts.append(f"and {len(unknown) - 10} more")
    noun = "unknown field" if len(unknown) == 1 else "unknown fields"
    return f"{noun} {', '.join(parts)}; known fields: {', '.join(known)}"


#: Per request model: its field names, the keys it accepts, and each field's name, alias
#: and JSON-kind check, found once (issue 9: the check runs for every nested model of every
#: request).
_PLANS: dict[type, tuple[list[str], frozenset[str],
                         tuple[tuple[str, str | None, Callable[[Any], str | None]], ...]]] = {}


def _plan(cls: type[RequestModel]) -> tuple[
        list[str], frozenset[str], tuple[tuple[str, str | None, Callable[[Any], str | None]], ...]]:
    plan = _PLANS.get(cls)
    if plan is None:
        known = list(cls.model_fields)
        allowed = (set(known) | {f.alias for f in cls.model_fields.values() if f.alias}
                   | cls.form_siblings)
        checks = tuple((name, info.alias, _checker(info.annotation))
                       for name, info in cls.model_fields.items())
        plan = _PLANS[cls] = (known, frozenset(allowed), checks)
    return plan


def _nul_at(value: Any, path: str) -> str | None:
    """The path of the first text (key or value) in ``value`` holding U+0000, or None.  A
    rig description holding it was stored on SQLite, a 500 on PostgreSQL, and then the
    SQLite store could not be copied to PostgreSQL at all (an operator pass)."""
    if isinstance(value, str):
        return path if "\x00" in value else None
    if isinstance(value, dict):
        for k, v in value.items():
            here = f"{path}.{k}" if path else str(k)
            if isinstance(k, str) and "\x00" in k:
                return path or "a key"
            if isinstance(v, str | dict | list) and (found := _nul_at(v, here)) is not None:
                return found
    elif isinstance(value, list):
        for i, v in enumerate(value):
            if isinstance(v, str | dict | list) and (
                    found := _nul_at(v, f"{path}[{i}]")) is not None:
                return found
    return None


class RequestModel(BaseModel):
    """Base of every request model: unknown fields are refused, never silently ignored.

    A misspelt key (``"flow_b"`` for ``flow_B``) would otherwise be dropped and the request
    answered as if the quantity had not been sent.  The 422 names every unknown field and
    suggests the closest known name (:func:`difflib.get_close_matches`).
    """

    model_config = ConfigDict(extra="forbid")

    #: Keys that arrive with the model but belong to the operation's other parameters
    #: (the file part of a multipart form beside its form model); not reported as unknown.
    form_siblings: ClassVar[frozenset[str]] = frozenset()
    #: Compare the values' JSON kinds with the documented ones (off for form models, whose
    #: values all arrive as text).
    json_kinds: ClassVar[bool] = True
    #: Names other operations give a field of this model (``load_force`` of a diagnosis
    #: record for the ``load`` of a simulation): the 422 of such a key names this one.
    synonyms: ClassVar[Mapping[str, str]] = {}
    #: A field that wraps a document (``document`` of a rig) and the keys that document
    #: holds: a body of those keys sent bare is told to wrap them, not "did you mean
    #: 'comment'?" (a user pass sent a rig file as the body of ``POST /rigs``).
    wraps: ClassVar[tuple[str, frozenset[str]] | None] = None

    @model_validator(mode="before")
    @classmethod
    def _refuse_unknown_fields(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        known, allowed, checks = _plan(cls)
        unknown = [str(k) for k in data if k not in allowed]
        if unknown and cls.wraps is not None and cls.wraps[0] not in data \
                and set(unknown) & cls.wraps[1]:
            raise PydanticCustomError(
                "extra_forbidden", f"unknown fields {', '.join(map(repr, unknown[:10]))}: "
                f"these are the fields of a {cls.wraps[0]} itself; send it inside the "
                f"body's {cls.wraps[0]!r} field ({{\"{cls.wraps[0]}\": {{...}}}}; known "
                f"fields: {', '.join(known)})", {"unknown_field": unknown[0][:100]})
        if unknown:
            raise PydanticCustomError(
                "extra_forbidden", _unknown_field_message(unknown, known, cls.synonyms),
                {"unknown_field": unknown[0][:100]},
            )
        if (where := _nul_at(data, "")) is not None:
            raise PydanticCustomError(
                "string_nul", f"{where or 'a key'}: the text holds the NUL character (U+0000), "
                "which the store cannot keep (PostgreSQL refuses it)", {"unknown_field": where})
        if cls.json_kinds:
            for name, alias, check in checks:
                key = alias if alias in data else name
                if key not in data:
                    continue
                problem = check(data[key])
                if problem:
                    raise PydanticCustomError("json_type", f"{key}: {problem}",
                                              {"unknown_field": key})
        return data


class UploadForm(RequestModel):
    """Base of the form models sent beside a file part (multipart uploads).

    FastAPI hands the whole form, the ``file`` part included, to the model: ``file`` is let
    through (the operation's body schema adds it beside these fields, so the model's own
    schema stays open), every other unknown field is refused by :class:`RequestModel`'s check
    with the close name suggested, and values are not compared as JSON kinds (a form sends
    text).
    """

    model_config = ConfigDict(extra="ignore")
    form_siblings = frozenset({"file"})
    json_kinds = False


def not_nullable(*names: str) -> Callable[[dict[str, Any]], None]:
    """``json_schema_extra`` of an update model whose ``names`` may be left out, not nulled.

    Such fields are ``X | None = None`` in Python (absent means "unchanged") and refuse an
    explicit null (:func:`reject_null`); their schema must then not offer null either.
    """

    def strip(schema: dict[str, Any]) -> None:
        for name in names:
            prop = schema.get("properties", {}).get(name)
            if prop is None:
                continue
            options = [o for o in prop.pop("anyOf", []) if o.get("type") != "null"]
            if len(options) == 1:
                prop.update(options[0])
            elif options:
                prop["anyOf"] = options
            if prop.get("default", "") is None:
                del prop["default"]

    return strip


class PublicModel(BaseModel):
    """Base of the models the API returns: built from ORM rows by attribute."""

    model_config = ConfigDict(from_attributes=True)


class ErrorDetail(BaseModel):
    """One problem with a request."""

    type: str = Field(
        description="Error class of hydrodiag's exception tree [-]",
        examples=["InputError", "NotFoundError", "AuthError"],
    )
    message: str = Field(
        description="What is wrong, for a person [-]",
        examples=["Input should be greater than 0"],
    )
    field: str | None = Field(
        default=None,
        description="Dotted path of the offending field, when there is one [-]",
        examples=["points[2].bypass_flow_m3s"],
    )
    details: list[dict[str, Any]] | None = Field(
        default=None,
        description="Every validation problem as {field, message}, for 422 responses [-]",
        examples=[[{"field": "points[2].bypass_flow_m3s", "message": "must be > 0"}]],
    )
    request_id: str | None = Field(
        default=None,
        description="Id of the request, as echoed in the X-Request-ID header and written "
                    "in the service log [-]",
        examples=["3f2a9c0e5b7d41a8b6c2d9e0f1a2b3c4"],
    )


class ErrorBody(BaseModel):
    """The body of every error response."""

    error: ErrorDetail = Field(
        description="The error [-]",
        examples=[{"type": "NotFoundError", "message": "no rig with id 7", "field": "rig_id"}],
    )


class Page(BaseModel, Generic[T]):
    """One page of a list; subclassed per resource as ``<Resource>List``."""

    items: list[T] = Field(description="The items of this page [-]", examples=[[]])
    total: int = Field(
        ge=0, description="Number of items in the whole list [-]", examples=[42]
    )
    limit: int = Field(ge=1, description="Largest page size asked for [-]", examples=[50])
    offset: int = Field(ge=0, description="Items skipped before this page [-]", examples=[0])


def error_doc(description: str) -> dict[str, Any]:
    """OpenAPI entry for an error response with the common body."""
    return {"model": ErrorBody, "description": description}


#: Error responses documented on every route of the API.
ERROR_RESPONSES: dict[int | str, dict[str, Any]] = {
    401: error_doc("Missing or wrong API key (header X-API-Key)"),
    403: error_doc("The API key's scope (read, write, admin) does not allow this operation; "
                   "see x-hydrodiag-scope"),
    404: error_doc("Unknown id"),
    409: error_doc("Conflicts with stored state"),
    413: error_doc("Request body over the size limit (HYDRODIAG_MAX_BODY_BYTES)"),
    422: error_doc("Invalid input (also an undecodable body or unknown field); `field` "
                   "names it"),
    429: error_doc("Too many requests for this API key (HYDRODIAG_RATE_LIMIT_PER_MINUTE); "
                   "see Retry-After"),
    # every operation reaches the store: a locked or unreachable one answers 503 with
    # Retry-After on any of them, where only /diagnose and /ready listed it (an API
    # client's pass)
    503: error_doc("The store does not answer now (locked past HYDRODIAG_DB_LOCK_TIMEOUT, "
                   "unreachable, or not migrated); nothing of the request was stored; "
                   "retry after Retry-After"),
}


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
