"""The console's router: every route logged in, every answer with the security headers.

:class:`ConsoleRoute` wraps each console handler: a request without a valid login cookie
is sent to the login page, an error of :mod:`sim.errors` (or of request validation)
becomes an error page with the API's status, type, field and message, and every answer
gets :data:`app.console.web.SECURITY_HEADERS`.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Annotated, Any

from fastapi import APIRouter, Depends, Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute
from starlette.exceptions import HTTPException as StarletteHTTPException

from app.api.deps import SessionDep, count_rate
from app.api.query_check import known_form, known_query
from app.console.web import SECURITY_HEADERS, console_key, login_url, page, redirect
from app.db.models import ApiKey
from app.errors import first_problem, status_for
from app.security import Scope
from sim.errors import AuthError, HydrodiagError, InputError

__all__ = ["ConsoleKeyDep", "ConsoleRoute", "error_of", "filter_error", "new_router",
           "write_refusal"]


def error_of(exc: Exception) -> dict[str, Any]:
    """The API's error body (type, message, field) of ``exc``, for a page."""
    if isinstance(exc, RequestValidationError):
        exc = first_problem(exc.errors())
    assert isinstance(exc, HydrodiagError)
    return {"type": type(exc).__name__, "message": exc.message, "field": exc.field}


def write_refusal(key: ApiKey, what: str) -> dict[str, Any] | None:
    """The error a page shows when the logged-in ``key`` may not do ``what`` (storing or
    changing something needs scope ``write``); ``None`` when it may."""
    if Scope(key.scope).allows(Scope.WRITE):
        return None
    return {"type": "ScopeError", "field": "api_key",
            "message": f"{what} needs a key of scope 'write' or above; this console is "
                       f"logged in with a {key.scope!r} key"}


def filter_error(exc: HydrodiagError) -> dict[str, Any]:
    """The error a list page shows above its filter form (:func:`error_of`, saying the
    page lists nothing until the filter is corrected, rather than "nothing was stored")."""
    return error_of(exc) | {"note": "Nothing is listed until the filter is corrected."}


class ConsoleRoute(APIRoute):
    """A console route (module docstring)."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        """Wrap the handler: login redirect, error pages, security headers."""
        handler = super().get_route_handler()

        async def wrapped(request: Request) -> Response:
            try:
                response = await handler(request)
            except AuthError:
                return redirect(login_url(request))
            except (HydrodiagError, RequestValidationError) as exc:
                status = 422 if isinstance(exc, RequestValidationError) else status_for(exc)
                return page(request, "error.html", status_code=status, error=error_of(exc))
            except StarletteHTTPException as exc:
                if exc.status_code != 400:
                    raise
                # the form itself could not be read (a field over the multipart part limit
                # of 1 MiB): the console's page, not the API's JSON
                error = {"type": InputError.__name__, "field": "body",
                         "message": f"the form could not be read: {exc.detail} (a pasted "
                                    "text is at most 1 MiB; upload a larger batch as a CSV)"}
                return page(request, "error.html", status_code=422, error=error)
            for name, value in SECURITY_HEADERS.items():
                response.headers.setdefault(name, value)
            return response

        return wrapped


def _key(request: Request, session: SessionDep) -> ApiKey:
    """The logged-in key, counted against its rate as an API request is (the console ran
    simulations on a key whose API quota was spent: a security review's pass)."""
    key = console_key(request, session)
    if not (request.method == "GET" and request.url.path.startswith("/console/jobs")):
        # a job's page reloads itself every 2 s while it runs: counted, it spent a limit
        # of 30 a minute by itself (a verification pass); it reads, it computes nothing
        count_rate(request, key.prefix)
    return key


#: The API key of the logged-in browser (redirects to the login page without one).
ConsoleKeyDep = Annotated[ApiKey, Depends(_key)]


def new_router(*, checked: bool = True) -> APIRouter:
    """A router for console pages (``/console``, hidden from the OpenAPI document) whose
    unknown query parameters and form fields are refused as the API's are
    (:mod:`app.api.query_check`); ``checked=False`` for the catch-all of paths the console
    lacks, whose answer is its "no such page"."""
    checks = [Depends(known_query), Depends(known_form)] if checked else []
    return APIRouter(prefix="/console", route_class=ConsoleRoute, include_in_schema=False,
                     dependencies=checks)
