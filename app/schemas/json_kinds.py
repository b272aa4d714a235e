"""The JSON kind of a request's values against the kind its schema documents: pydantic's
lax mode reads ``true`` as 1, ``"1.5"`` as 1.5 and ``0.5`` as a date; the API refuses them."""

from __future__ import annotations

import datetime as dt
import types
import typing
from collections.abc import Callable
from typing import Annotated, Any

from app.schemas.times import iso_only

__all__ = ["json_kind_checker", "json_type_problem"]


def json_type_problem(annotation: Any, value: Any) -> str | None:
    """Why ``value`` (decoded JSON) is not of the JSON type ``annotation`` documents.

    pydantic's lax mode turns ``true`` into 1, ``"1.5"`` into 1.5 and ``0.5`` into a date;
    the OpenAPI document says integer, number, date-time, so such values are refused.
    Only the JSON kinds are compared (booleans, numbers, strings; lists and maps item by
    item); ranges and formats stay pydantic's.
    """
    return json_kind_checker(annotation)(value)


#: The check of each annotation met, built once (:func:`json_kind_checker`), with the annotation
#: kept alive beside it (the key is its ``id``).
_CHECKERS: dict[int, tuple[Any, Callable[[Any], str | None]]] = {}


def json_kind_checker(annotation: Any) -> Callable[[Any], str | None]:
    """:func:`json_type_problem` for ``annotation``, its type inspected once: the check
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
        return json_kind_checker(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        options = [json_kind_checker(a) for a in typing.get_args(annotation) if a is not type(None)]

        def union(value: Any) -> str | None:
            if value is None:
                return None
            problems = [check(value) for check in options]
            return None if any(p is None for p in problems) else problems[0]
        return union
    if origin in (list, tuple, set, frozenset):
        args = typing.get_args(annotation)
        item_check = json_kind_checker(args[0]) if args else _no_problem

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
        value_check = json_kind_checker(args[1]) if len(args) == 2 else _no_problem

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
