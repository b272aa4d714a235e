"""The one place where hydrodiag's exception tree becomes HTTP.

The tree is :mod:`sim.errors`; the service adds :class:`ServiceUnavailableError` (and its
``ServiceBusyError`` and ``WarmingUpError``), ``PayloadTooLargeError``, ``ScopeError`` and
``RateLimitError``, all under its root.  Every error response has the same body::

    {"error": {"type": "InputError", "message": "must be > 0", "field": "points[2].bypass_flow_m3s",
               "request_id": "3f2a..."}}

=============================  ======  =======================================
class                          status  when
=============================  ======  =======================================
``AuthError``                  401     missing or wrong ``X-API-Key``
``ScopeError``                 403     the key's scope does not allow the operation
``NotFoundError``              404     unknown id (in the path or the body)
``ConflictError``              409     duplicate name, deleting what is in use, a row
                                       changed by a concurrent request (StaleDataError)
``PayloadTooLargeError``        413     the body is over ``max_body_bytes`` (uploads:
                                       ``max_upload_bytes``)
``RateLimitError``             429     the key's requests per minute are spent
``InputError`` and subclasses  422     invalid input, names the field
``SimulationError``            500     the solver failed
``ServiceUnavailableError``    503     the database is unreachable or not migrated (an
                                       ``OperationalError`` of the driver too, with
                                       ``Retry-After``: nothing of the request stored)
``ServiceBusyError``           503     too many diagnoses or jobs queued (with
                                       ``Retry-After``)
``WarmingUpError``             503     starting: the stored rigs are still loading
=============================  ======  =======================================

Any other exception is a 500 ``InternalError`` whose body names the ``request_id`` under
which the service log holds its traceback (:class:`CatchAllMiddleware`: once only, and as a
JSON line where the log is JSON).

Request validation by pydantic is reported as ``InputError`` with the same body; the first
problem is in ``field``/``message`` and all of them are listed in ``details``.  A body that
cannot be decoded (not UTF-8, not JSON, a broken multipart form) is a 422 on ``body``; an
integer too large for the store is a 422; a 405 lists in ``Allow`` every method the path
has.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.routing import iter_route_contexts
from sqlalchemy.exc import InterfaceError, OperationalError
from sqlalchemy.orm.exc import StaleDataError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.logs import request_id_of
from sim.errors import (
    AuthError,
    ConflictError,
    HydrodiagError,
    InputError,
    NotFoundError,
    SimulationError,
)

__all__ = [
    "CatchAllMiddleware",
    "PayloadTooLargeError",
    "RateLimitError",
    "ScopeError",
    "ServiceBusyError",
    "ServiceUnavailableError",
    "WarmingUpError",
    "database_unavailable",
    "error_response",
    "first_problem",
    "format_location",
    "install_error_handlers",
    "plain_message",
    "status_for",
]

logger = logging.getLogger("hydrodiag.app")


class ServiceUnavailableError(HydrodiagError):
    """The service cannot answer now: the database is unreachable or not migrated."""


class WarmingUpError(ServiceUnavailableError):
    """The service is starting: its stored rigs are still loading (503; logged at info,
    as every readiness probe of a start meets it)."""


class ServiceBusyError(ServiceUnavailableError):
    """The service has as much work queued as it accepts (``diagnosis_queue``); retry in
    ``retry_after`` seconds."""

    def __init__(self, message: str, *, retry_after: int, field: str | None = None) -> None:
        super().__init__(message, field=field)
        self.retry_after = retry_after


class PayloadTooLargeError(HydrodiagError):
    """The request body is larger than the service accepts (``max_body_bytes``; a file
    upload: ``max_upload_bytes``)."""


class ScopeError(HydrodiagError):
    """The API key is valid but its scope (read, write, admin) does not allow the operation."""


class RateLimitError(HydrodiagError):
    """The API key has sent more requests than ``rate_limit_per_minute`` allows."""

    def __init__(self, message: str, *, retry_after: int, field: str | None = None) -> None:
        super().__init__(message, field=field)
        self.retry_after = retry_after


_STATUS: dict[type[HydrodiagError], int] = {
    AuthError: 401,
    ScopeError: 403,
    NotFoundError: 404,
    ConflictError: 409,
    PayloadTooLargeError: 413,
    RateLimitError: 429,
    InputError: 422,
    SimulationError: 500,
    ServiceUnavailableError: 503,
}

_LOCATION_ROOTS = frozenset({"body", "query", "path", "header", "cookie"})


def status_for(exc: HydrodiagError) -> int:
    """Return the HTTP status of ``exc``: that of its nearest mapped ancestor class."""
    for cls in type(exc).__mro__:
        if cls in _STATUS:
            return _STATUS[cls]
    return 500


def format_location(loc: Sequence[int | str]) -> str | None:
    """Turn a pydantic error location into a dotted field path.

    ``("body", "points", 2, "opening_turns")`` becomes ``"points[2].opening_turns"``; the
    leading ``body``/``query``/... is dropped unless it is all there is.
    """
    parts = list(loc)
    if len(parts) > 1 and parts[0] in _LOCATION_ROOTS:
        parts = parts[1:]
    path = ""
    for part in parts:
        if part == "[key]":  # pydantic's marker for a bad mapping key: the key is the field
            continue
        if isinstance(part, int):
            path += f"[{part}]"
        else:
            path += f".{part}" if path else str(part)
    return path or None


def error_response(
    status: int,
    type_: str,
    message: str,
    field: str | None = None,
    *,
    details: list[dict[str, Any]] | None = None,
    headers: Mapping[str, str] | None = None,
    request: Request | None = None,
) -> JSONResponse:
    """Build the JSON error response every handler returns.

    With ``request``, the body carries the request's id (``error.request_id``, the one
    echoed in ``X-Request-ID`` and logged; see :mod:`app.logs`).
    """
    error: dict[str, Any] = {"type": type_, "message": message, "field": field}
    if details is not None:
        error["details"] = details
    request_id = None if request is None else request_id_of(request.scope)
    if request_id is not None:
        error["request_id"] = request_id
    return JSONResponse({"error": error}, status_code=status, headers=headers)


def response_for(exc: HydrodiagError, *, headers: Mapping[str, str] | None = None,
                 request: Request | None = None) -> JSONResponse:
    """The error response of ``exc``: its status from :func:`status_for` (the one mapping of
    the exception tree to HTTP), its type, message, field and details; middleware that
    answers before any route (body limits, idempotency keys) builds its refusals here too."""
    return error_response(status_for(exc), type(exc).__name__, exc.message, exc.field,
                          headers=headers, details=exc.details, request=request)


async def _hydrodiag_error(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, HydrodiagError)
    status = status_for(exc)
    if isinstance(exc, ServiceBusyError | WarmingUpError):
        # expected while starting or under load, and a readiness probe meets it every few
        # seconds of every start: a run of warnings at each restart (an upgrade pass); the
        # metrics count them.  A store that does not answer stays a warning (a
        # verification pass found it demoted with them)
        logger.info("%s: %s", type(exc).__name__, exc)
    elif status == 503:
        logger.warning("%s: %s", type(exc).__name__, exc)
    elif status >= 500:
        logger.error("%s: %s", type(exc).__name__, exc)
    headers = {"WWW-Authenticate": "APIKey"} if status == 401 else None
    if isinstance(exc, RateLimitError | ServiceBusyError):
        headers = {"Retry-After": str(exc.retry_after)}
    return response_for(exc, headers=headers, request=request)


def first_problem(errors: Sequence[Mapping[str, Any]]) -> InputError:
    """The first of pydantic's ``errors`` as the :class:`InputError` the API answers with:
    its field as :func:`_location` names it (a JSON type or an unknown key named down to
    the key: ``record.rig_id``, where the console and the CLI once said ``record``)."""
    if not errors:
        return InputError("invalid input")
    return InputError(_message(errors[0]) or "invalid", field=_location(errors[0]))


def _location(err: Mapping[str, Any]) -> str | None:
    loc = tuple(err.get("loc", ()))
    if err.get("type") == "json_invalid":  # loc ends with the character's position
        return "body"
    ctx = err.get("ctx") or {}
    if "unknown_field" in ctx:  # the strict base reports on the model: add the field
        loc = (*loc, ctx["unknown_field"])
    return format_location(loc)


def plain_message(message: str) -> str:
    """A validator's sentence as it wrote it, without pydantic's ``Value error, `` (a fault
    name refused by POST /scenarios kept it; so did an invalid configuration)."""
    return message.removeprefix("Value error, ")


def _message(err: Mapping[str, Any]) -> str:
    message = plain_message(str(err.get("msg", "")))
    loc = tuple(err.get("loc", ()))
    if err.get("type") == "json_invalid" and loc and isinstance(loc[-1], int):
        message = f"{message} at character {loc[-1]}"
    return message


async def _validation_error(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, RequestValidationError)
    problems = [(_location(err), _message(err)) for err in exc.errors()]
    field, message = problems[0] if problems else (None, "invalid request")
    kind = request.headers.get("content-type", "").split(";", 1)[0].strip().lower()
    if field == "body" and kind not in ("application/json", "multipart/form-data"):
        # FastAPI reads a body of another type as text: "should be a valid dictionary"; a
        # form route names its missing fields, so "body" is a route that wanted JSON
        hint = (": curl -d sends a form, add -H 'Content-Type: application/json'"
                if kind == "application/x-www-form-urlencoded" else "")
        message = (f"the body must be JSON, sent with Content-Type: application/json (it "
                   f"came as {kind or 'no content type'!r}{hint})")
        problems[0] = (field, message)
    details: list[dict[str, Any]] = [{"field": f, "message": m} for f, m in problems]
    return error_response(422, InputError.__name__, message, field, details=details,
                          request=request)


def allowed_methods(request: Request) -> list[str]:
    """Every method some route of the application answers on the request's path."""
    methods: set[str] = set()
    for context in iter_route_contexts(request.app.router.routes):
        match, _ = context.route.matches(request.scope)
        if match != Match.NONE:
            methods |= set(context.methods or ())
    return sorted(methods)


async def _http_error(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, StarletteHTTPException)
    if exc.status_code == 400:  # FastAPI could not decode the body (not UTF-8, bad form)
        return error_response(422, InputError.__name__,
                              f"the body could not be read: {exc.detail}", "body",
                              request=request)
    headers = dict(exc.headers or {})
    if exc.status_code == 405:
        headers["Allow"] = ", ".join(allowed_methods(request))
    type_ = NotFoundError.__name__ if exc.status_code == 404 else "HTTPError"
    return error_response(exc.status_code, type_, str(exc.detail), headers=headers or None,
                          request=request)


async def _overflow_error(request: Request, exc: Exception) -> JSONResponse:
    # a bound missed in some schema: the database driver refuses an integer; still the
    # caller's input, never a 500
    logger.warning("integer out of range reached the store: %s", exc)
    return error_response(422, InputError.__name__,
                          f"an integer is out of range (at most {2**31 - 1}): {exc}",
                          request=request)


async def _stale_row(request: Request, exc: Exception) -> JSONResponse:
    # a concurrent request deleted or rewrote the row this one was updating (found by the
    # fuzzer: PATCH of a throttle table racing its DELETE); nothing of this request stored
    logger.warning("concurrent change of a stored row: %s", exc)
    return error_response(409, ConflictError.__name__,
                          "the item was changed or deleted by another request while this one "
                          "wrote it; nothing was stored: read it again and retry",
                          request=request)


#: seconds a client is asked to wait when the database did not answer
DATABASE_RETRY_S = 5


def database_unavailable(request: Request, exc: Exception) -> JSONResponse:
    """The 503 of a store that does not answer (``exc``: the driver's error), with
    ``Retry-After``: the transaction was not committed, so a retry is safe — a 500 told
    clients and balancers it was a bug."""
    logger.warning("database unavailable: %s", type(exc).__name__,
                   extra={"request_id": request_id_of(request.scope)})
    return error_response(503, ServiceUnavailableError.__name__,
                          f"the database did not answer ({type(exc).__name__}); nothing of "
                          "this request was stored: retry shortly",
                          headers={"Retry-After": str(DATABASE_RETRY_S)}, request=request)


async def _database_unavailable(request: Request, exc: Exception) -> JSONResponse:
    return database_unavailable(request, exc)


def _internal_error(request: Request, exc: BaseException) -> JSONResponse:
    logger.error("unexpected error", exc_info=exc,
                 extra={"request_id": request_id_of(request.scope)})
    return error_response(500, "InternalError",
                          "internal error; see the service log under this request_id",
                          request=request)


async def _unexpected_error(request: Request, exc: Exception) -> JSONResponse:
    return _internal_error(request, exc)


class CatchAllMiddleware:
    """Answer an unexpected exception with the 500 body inside the middleware stack.

    Starlette sends the ``Exception`` handler's answer from its outermost middleware and
    then re-raises, so uvicorn logged every traceback a second time, as plain text in a
    JSON log, and the handler's own line had no ``request_id`` (the request's context was
    gone by then).  Added first, this middleware sits inside the request log and metrics
    middlewares: the line carries the id and the exception goes no further.  An exception
    after the response started is re-raised (the connection is broken off).
    """

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = False

        async def watch(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, receive, watch)
        except Exception as exc:
            if started:
                raise
            await _internal_error(Request(scope), exc)(scope, receive, send)


def install_error_handlers(app: FastAPI) -> None:
    """Register the handlers that map every error to the common JSON body."""
    app.add_exception_handler(HydrodiagError, _hydrodiag_error)
    app.add_exception_handler(RequestValidationError, _validation_error)
    app.add_exception_handler(StarletteHTTPException, _http_error)
    app.add_exception_handler(OverflowError, _overflow_error)
    app.add_exception_handler(StaleDataError, _stale_row)
    app.add_exception_handler(OperationalError, _database_unavailable)
    app.add_exception_handler(InterfaceError, _database_unavailable)
    app.add_exception_handler(Exception, _unexpected_error)
