"""Shapes shared by every resource: the strict request base, bounded ids, error body,
pages of a list, timestamps."""

from __future__ import annotations

import difflib
from collections.abc import Callable
from datetime import datetime
from typing import Annotated, Any, ClassVar, Generic, TypeVar

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

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
    "Timestamp",
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


def _unknown_field_message(unknown: list[str], known: list[str]) -> str:
    parts = []
    for name in unknown[:10]:
        by_case = {k.lower(): k for k in known}
        # a case slip ("flow_b" for "flow_B") first: plain ratios would tie it with "flow_C"
        close = [by_case[c] for c in difflib.get_close_matches(name.lower(), list(by_case),
                                                               n=1, cutoff=0.6)]
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        parts.append(f"{name[:100]!r}{hint}")
    if len(unknown) > 10:
        parts.append(f"and {len(unknown) - 10} more")
    noun = "unknown field" if len(unknown) == 1 else "unknown fields"
    return f"{noun} {', '.join(parts)}; known fields: {', '.join(known)}"


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

    @model_validator(mode="before")
    @classmethod
    def _refuse_unknown_fields(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        known = list(cls.model_fields)
        allowed = set(known) | {f.alias for f in cls.model_fields.values() if f.alias}
        allowed |= cls.form_siblings
        unknown = [str(k) for k in data if k not in allowed]
        if unknown:
            raise PydanticCustomError(
                "extra_forbidden", _unknown_field_message(unknown, known),
                {"unknown_field": unknown[0][:100]},
            )
        return data


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
    404: error_doc("Unknown id"),
    409: error_doc("Conflicts with stored state"),
    413: error_doc("Request body over the size limit (HYDRODIAG_MAX_BODY_BYTES)"),
    422: error_doc("Invalid input (also an undecodable body or unknown field); `field` "
                   "names it"),
}
