"""Unknown query parameters and form fields are refused, as unknown body fields are.

``GET /diagnoses?rigid=1`` (a typo of ``rig_id``) answered the unfiltered list; a client
could not tell a filter it misspelt from one that matched everything.  :func:`known_query`
runs before every operation of the API (not ``/health`` and the other operations of
``ops``, which take no parameters and must cost nothing) and of the console, and answers
422 naming the parameter, with the close known name.  :func:`known_form` does the same for
the fields of a console form (``/console/simulate?lod=4200`` simulated at the default
2.1 kN, a ``smaple_rate`` field of an import was dropped: a code review).
"""

from __future__ import annotations

import difflib
from collections.abc import Callable
from typing import Any

from fastapi import Request
from fastapi.dependencies.models import Dependant
from pydantic import BaseModel

from sim.errors import InputError

__all__ = ["known_form", "known_query", "query_names"]

#: the query parameter names of each route, by the route's id
_NAMES: dict[int, frozenset[str]] = {}
#: the form field names of each route, by the route's id
_FORM_NAMES: dict[int, frozenset[str]] = {}
#: request bodies that are forms
_FORM_TYPES = ("application/x-www-form-urlencoded", "multipart/form-data")


def _model(annotation: Any) -> type[BaseModel] | None:
    return annotation if isinstance(annotation, type) and issubclass(annotation, BaseModel) \
        else None


def query_names(dependant: Dependant) -> frozenset[str]:
    """The names of the query parameters ``dependant`` and its dependencies read (the
    fields of a query model, ``Annotated[Model, Query()]``, one by one)."""
    names: set[str] = set()
    stack = [dependant]
    while stack:
        current = stack.pop()
        for param in current.query_params:
            model = _model(param.field_info.annotation)
            if model is None:
                names.add(param.alias)
            else:
                names.update(f.alias or name for name, f in model.model_fields.items())
        stack.extend(current.dependencies)
    return frozenset(names)


def form_names(dependant: Dependant) -> frozenset[str]:
    """The names of the form fields (and files) ``dependant`` and its dependencies read."""
    names: set[str] = set()
    stack = [dependant]
    while stack:
        current = stack.pop()
        names.update(param.alias for param in current.body_params)
        stack.extend(current.dependencies)
    return frozenset(names)


def _route_names(request: Request, cache: dict[int, frozenset[str]],
                 read: Callable[[Dependant], frozenset[str]]) -> frozenset[str] | None:
    """The names ``read`` finds in the request's operation, cached by route; ``None`` for
    a request no operation answers."""
    route = request.scope.get("route")
    dependant = getattr(route, "dependant", None)
    if dependant is None:
        return None
    names = cache.get(id(route))
    if names is None:
        names = cache[id(route)] = read(dependant)
    return names


def _unknown(key: str, names: frozenset[str], what: str) -> InputError:
    close = difflib.get_close_matches(key, sorted(names), n=1)
    known = ", ".join(sorted(names)) or "none"
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return InputError(f"unknown {what} {key!r} (known: {known}){hint}", field=key)


async def known_form(request: Request) -> None:
    """Refuse a form field the operation does not read (422 naming it); a body that is not
    a form is left to the operation.

    Raises
    ------
    InputError
        ``field`` is the field's name.
    """
    kind = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if request.method not in ("POST", "PUT", "PATCH") or kind not in _FORM_TYPES:
        return
    names = _route_names(request, _FORM_NAMES, form_names)
    if names is None:
        return
    # the operation parsed the form already (FastAPI reads the body before the
    # dependencies): this is the request's cached copy
    for key in await request.form():
        if key not in names:
            raise _unknown(key, names, "form field")


async def known_query(request: Request) -> None:
    """Refuse a query parameter the operation does not read (422 naming it).

    Raises
    ------
    InputError
        ``field`` is the parameter's name.
    """
    if not request.query_params:
        return
    names = _route_names(request, _NAMES, query_names)
    if names is None:
        return
    for key in request.query_params:
        if key not in names:
            raise _unknown(key, names, "query parameter")
