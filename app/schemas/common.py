"""Shapes shared by every resource: the strict request base, bounded ids, error body,
pages of a list.  Times are :mod:`app.schemas.times`; the JSON-kind check of values is
:mod:`app.schemas.json_kinds`."""

from __future__ import annotations

import difflib
from collections.abc import Callable, Mapping
from typing import Annotated, Any, ClassVar, Generic, TypeVar

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

from app.schemas.json_kinds import json_kind_checker

__all__ = [
    "ERROR_RESPONSES",
    "MAX_ID",
    "MAX_OFFSET",
    "ErrorBody",
    "ErrorDetail",
    "FiniteFloat",
    "IdInt",
    "Page",
    "PublicModel",
    "RequestModel",
    "UploadForm",
    "error_doc",
    "not_nullable",
    "reject_null",
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

#: A float that must be finite (no NaN, no infinity).
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]


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
        checks = tuple((name, info.alias, json_kind_checker(info.annotation))
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

