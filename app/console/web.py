"""What every console page shares: templates, the security headers, the login cookie.

Login: the API key is posted once per browser session to ``/console/login``; the answer
sets a cookie ``hd_console = <key id>.<issued at>.<nonce>.<HMAC-SHA256>`` (HttpOnly,
SameSite=Strict, Secure when served over HTTPS; no Max-Age, so it ends with the browser
session, and refused after :data:`SESSION_LIFETIME_S`).  The key itself is never stored in
the cookie or put in a URL; each request checks that the key still exists and is not
revoked, and that the session was not logged out (logout keeps the cookie's digest on the
server until it would have expired, so a copy of it is refused too).  The random nonce
makes every login's cookie its own: two logins with one key in the same second had the
same cookie, and one logout ended both.  The signing secret
is the ``console_secret`` setting (``HYDRODIAG_CONSOLE_SECRET``, ≥ 32 characters, no
well-known default) or, without it, a random one kept in ``<data_dir>/console-secret`` (so
every worker process of one service shares it).

Every console response carries :data:`SECURITY_HEADERS`: a Content-Security-Policy that
allows only the service's own origin (no inline script or style), no framing, no sniffing.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import os
import re
import secrets
import threading
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any
from urllib.parse import quote

from fastapi import Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from jinja2 import Environment, FileSystemLoader, pass_context, select_autoescape
from jinja2.runtime import Context
from markupsafe import Markup
from sqlalchemy.orm import Session

from app.db.models import ApiKey
from app.services.console_logouts import end_session, is_ended
from app.services.keys import is_revoked
from app.settings import Settings
from diagnostics.plots import Chart, render_svg, shown_unit
from diagnostics.timeseries import CONDITION_CHANNELS
from sim.errors import AuthError

__all__ = ["COOKIE", "SECURITY_HEADERS", "SESSION_LIFETIME_S", "console_key",
           "end_console_session", "issue_cookie", "page", "redirect", "templates"]

COOKIE = "hd_console"
#: Longest a login lasts, even in a browser session that stays open [s].
SESSION_LIFETIME_S = 12 * 3600
#: Random bytes in each login cookie [-]: every login its own session (hex in the cookie).
NONCE_BYTES = 8
_NONCE = re.compile(f"[0-9a-f]{{{2 * NONCE_BYTES}}}")
SECURITY_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; script-src 'self'; style-src 'self'; "
    "img-src 'self' data:; form-action 'self'; frame-ancestors 'none'; base-uri 'self'; "
    "object-src 'none'",
    "X-Content-Type-Options": "nosniff",
    "X-Frame-Options": "DENY",
    "Referrer-Policy": "same-origin",
    "Cache-Control": "no-store",
}
_HERE = Path(__file__).parent
_SECRET_LOCK = threading.Lock()


def _si(value: Any, digits: int = 4) -> str:
    """A number with ``digits`` significant digits ("—" for none)."""
    if value is None:
        return "—"
    if isinstance(value, bool) or not isinstance(value, int | float):
        return str(value)
    if not math.isfinite(value):
        return "—"
    return f"{value:.{digits}g}"


def _interval(bounds: Any, digits: int = 3) -> str:
    """An interval ``(low, high)`` as "low … high" with ``digits`` significant digits, or
    more (up to 7) where fewer would print its ends alike: "6e-05 … 6e-05" stood for
    5.997e-05 … 6.002e-05 (a console pass)."""
    if not bounds:
        return "—"
    low, high = bounds[0], bounds[1]
    n = digits
    while n < 7 and _si(low, n) == _si(high, n) and low != high:
        n += 1
    return f"{_si(low, n)} … {_si(high, n)}"


def _svg(chart: Chart | None) -> Markup:
    """A chart as inline SVG (CSP-safe, written directly: :func:`diagnostics.plots.render_svg`)."""
    return Markup("") if chart is None else Markup(render_svg(chart))


templates = Environment(loader=FileSystemLoader(_HERE / "templates"),
                        autoescape=select_autoescape(["html"]), trim_blocks=True,
                        lstrip_blocks=True)
templates.filters["si"] = _si
#: a record's stated condition, each with its unit (a console pass: "load 2100,
#: back_pressure 0, oil_temperature 40" under "condition [SI]")
templates.globals["condition_units"] = {k: u.replace("degC", "°C")
                                        for k, u in CONDITION_CHANNELS.items()}
templates.filters["interval"] = _interval
templates.globals["display"] = shown_unit  # pressures in bar, flows in l/min, …
templates.filters["svg"] = _svg

#: an error's heading in words an operator reads, by the exception tree's class (the box
#: began "AuthError in api_key", "MeasurementError in …": a plant operator's pass)
ERROR_TITLES = {
    "AuthError": "Not logged in", "ScopeError": "Not allowed with this key",
    "NotFoundError": "Not found", "ConflictError": "Stored already",
    "InputError": "Please correct", "ParameterError": "Please correct",
    "RigFileError": "The rig description is refused", "CircuitError": "Not on this rig",
    "MeasurementError": "These readings cannot be used",
    "RateLimitError": "Too many requests", "ServiceBusyError": "Busy: try again shortly",
    "ServiceUnavailableError": "Not available: try again shortly",
    "WarmingUpError": "Starting: try again shortly",
    "SimulationError": "The simulation did not run", "SolverLimitError":
    "The simulation did not finish", "PayloadTooLargeError": "Too large",
}
templates.globals["error_title"] = lambda kind: ERROR_TITLES.get(str(kind), "Refused")


@pass_context
def _invalid(context: Context, *names: str) -> Markup:
    """`` aria-invalid="true" aria-describedby="form-error"`` on a control one of whose
    ``names`` the page's error names (the field itself, or the first or last part of its
    path: ``condition.load`` marks ``load``, ``record.p1`` the record's text), else nothing:
    errors were in an alert box tied to no control (an accessibility pass)."""
    error = context.get("error")
    field = str((error or {}).get("field") or "") if isinstance(error, dict) else ""
    if not field:
        return Markup("")
    parts = [p for p in re.split(r"[.\[\]]", field) if p]
    hit = field in names or (parts and (parts[0] in names or parts[-1] in names))
    return Markup(' aria-invalid="true" aria-describedby="form-error"') if hit else Markup("")


templates.globals["invalid"] = _invalid


def page(request: Request, template: str, status_code: int = 200, **context: Any
         ) -> HTMLResponse:
    """Render ``template`` as a console page with the security headers."""
    html = templates.get_template(template).render(request=request, **context)
    return HTMLResponse(html, status_code=status_code, headers=SECURITY_HEADERS)


def redirect(url: str) -> RedirectResponse:
    """A 303 redirect (after a form) with the security headers."""
    return RedirectResponse(url, status_code=303, headers=SECURITY_HEADERS)


def _secret(settings: Settings) -> bytes:
    if settings.console_secret is not None:
        return settings.console_secret.get_secret_value().encode()
    path = Path(settings.data_dir) / "console-secret"
    with _SECRET_LOCK:
        if not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            try:
                fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            except FileExistsError:  # another worker made it first
                pass
            else:
                with os.fdopen(fd, "w", encoding="utf-8") as f:
                    f.write(secrets.token_hex(32))
        return path.read_text(encoding="utf-8").strip().encode()


def _signature(secret: bytes, key_id: int, issued: int, nonce: str, prefix: str) -> str:
    message = f"{key_id}.{issued}.{nonce}.{prefix}".encode()
    return hmac.new(secret, message, hashlib.sha256).hexdigest()


def issue_cookie(response: Response, request: Request, key: ApiKey) -> None:
    """Set the login cookie for ``key`` on ``response``."""
    issued = int(time.time())
    nonce = secrets.token_hex(NONCE_BYTES)
    signature = _signature(_secret(request.app.state.settings), key.id, issued, nonce,
                           key.prefix)
    value = f"{key.id}.{issued}.{nonce}.{signature}"
    response.set_cookie(COOKIE, value, httponly=True, samesite="strict", path="/console",
                        secure=request.url.scheme == "https")


def console_key(request: Request, session: Session) -> ApiKey:
    """The API key the browser logged in with.

    Raises
    ------
    AuthError
        No cookie, a forged or expired one, or a key revoked since.
    """
    value = request.cookies.get(COOKIE, "")
    parts = value.split(".")
    if (len(parts) != 4 or not parts[0].isdigit() or not parts[1].isdigit()
            or not _NONCE.fullmatch(parts[2])):
        raise AuthError("log in with an API key", field="api_key")
    key_id, issued = int(parts[0]), int(parts[1])
    if time.time() - issued > SESSION_LIFETIME_S:
        raise AuthError("the console session has expired; log in again", field="api_key")
    key = session.get(ApiKey, key_id)
    secret = _secret(request.app.state.settings)
    if key is None or not hmac.compare_digest(
            parts[3], _signature(secret, key_id, issued, parts[2], key.prefix)):
        raise AuthError("log in with an API key", field="api_key")
    if is_revoked(key):
        raise AuthError("this API key has been revoked", field="api_key")
    if is_ended(session, value):
        raise AuthError("this console session was logged out; log in again", field="api_key")
    return key


def end_console_session(request: Request, session: Session) -> None:
    """End the session of the request's cookie on the server as well (a copy of it is
    refused from now on: :mod:`app.services.console_logouts`); a missing, forged or
    expired cookie has no session to end."""
    try:
        console_key(request, session)
    except AuthError:
        return
    value = request.cookies.get(COOKIE, "")
    issued = int(value.split(".")[1])
    end_session(session, value, datetime.fromtimestamp(issued + SESSION_LIFETIME_S, UTC))


def login_url(request: Request) -> str:
    """The login page, returning to the page asked for."""
    target = request.url.path + (f"?{request.url.query}" if request.url.query else "")
    return f"/console/login?next={quote(target, safe='')}"
