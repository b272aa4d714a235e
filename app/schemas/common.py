"""Shapes shared by every resource: error body, pages of a list, timestamps."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Generic, TypeVar

from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "ERROR_RESPONSES",
    "ErrorBody",
    "ErrorDetail",
    "FiniteFloat",
    "Page",
    "PublicModel",
    "Timestamp",
    "error_doc",
    "reject_null",
]

T = TypeVar("T")

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
    422: error_doc("Invalid input; `field` names it"),
}
