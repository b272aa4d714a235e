"""The service's log: one line per request with a request id, as JSON or text.

:class:`RequestLogMiddleware` gives every HTTP request an id: the client's ``X-Request-ID``
when it is well formed (1 to :data:`MAX_REQUEST_ID_LENGTH` characters of letters, digits
and ``-._:``), else a new random one (a malformed id is replaced, never logged).  The id is
echoed in the response's ``X-Request-ID`` header, put in the body of every error
(``error.request_id``, :mod:`app.errors`) and on every log line written while the request
runs.  When the request ends it logs one line on ``hydrodiag.access``: method, route
*template* (``/rigs/{rig_id}``, never the query string), status, duration, request id and
the id of the API key (never the key, never a body or a header's value).

:func:`configure_logging` sends the ``hydrodiag`` loggers to standard error, one JSON
object per line (``HYDRODIAG_LOG_FORMAT=json``, the default) or plain text (``text``).
``hydrodiag serve`` and :func:`app.main.create_service_app` call it; uvicorn's own access
log is then redundant (``serve`` turns it off; with ``uvicorn`` itself pass
``--no-access-log``).
"""

from __future__ import annotations

import json
import logging
import re
import secrets
import sys
import time
from contextvars import ContextVar
from datetime import UTC, datetime
from typing import Any, Literal, TextIO

from starlette.types import ASGIApp, Message, Receive, Scope, Send

__all__ = [
    "ACCESS_LOGGER",
    "CLIENT_CLOSED",
    "MAX_REQUEST_ID_LENGTH",
    "REQUEST_ID_HEADER",
    "AnswerWatch",
    "JsonFormatter",
    "RequestLogMiddleware",
    "configure_logging",
    "current_request_id",
    "request_id_of",
]

REQUEST_ID_HEADER = "X-Request-ID"
#: Longest request id accepted from a client [characters].
MAX_REQUEST_ID_LENGTH = 64
ACCESS_LOGGER = "hydrodiag.access"

_REQUEST_ID = re.compile(rf"[A-Za-z0-9._:-]{{1,{MAX_REQUEST_ID_LENGTH}}}")
_HEADER = REQUEST_ID_HEADER.lower().encode("ascii")
_current: ContextVar[str | None] = ContextVar("hydrodiag_request_id", default=None)

#: Attributes of a log record that are not extra fields.
_STANDARD = frozenset(vars(logging.makeLogRecord({}))) | {"message", "asctime", "taskName"}


def current_request_id() -> str | None:
    """The id of the request being answered in this context, if any."""
    return _current.get()


def request_id_of(scope: Scope) -> str | None:
    """The id :class:`RequestLogMiddleware` gave the request of ``scope``, if any."""
    state = scope.get("state") or {}
    value = state.get("request_id") if isinstance(state, dict) else None
    return value if isinstance(value, str) else None


def _accepted_id(scope: Scope) -> str:
    for name, value in scope.get("headers") or ():
        if name == _HEADER:
            text = value.decode("latin-1")
            if _REQUEST_ID.fullmatch(text):
                return text
            break
    return secrets.token_hex(16)


def _route_of(scope: Scope) -> str:
    path = getattr(scope.get("route"), "path", None)
    return str(path) if path else "<unmatched>"


def _key_id_of(scope: Scope) -> int | None:
    state = scope.get("state") or {}
    key = state.get("api_key") if isinstance(state, dict) else None
    try:
        key_id = getattr(key, "id", None)
    except Exception:
        # a key object whose session is gone (DetachedInstanceError) took the access line
        # of a 500 with it (an operator pass)
        return None
    return key_id if isinstance(key_id, int) else None


#: the status logged and counted for a request whose client went away before its answer
#: began (nginx's "client closed request"): a body cut off as too slow (app.nodelay) was
#: logged as the 422 the app then tried to send, with no key (a verification pass)
CLIENT_CLOSED = 499


class AnswerWatch:
    """What a request's client got: :attr:`status` is the answer's status, or
    :data:`CLIENT_CLOSED` when the client had gone before the answer began (its
    ``http.disconnect`` came while the app read the body); the wrapped :meth:`receive` and
    :meth:`send` are handed to the app."""

    def __init__(self, receive: Receive, send: Send) -> None:
        self._receive = receive
        self._send = send
        self.status = 500
        self._gone = False
        self._started = False

    async def receive(self) -> Message:
        """The client's next message, noting a disconnect before the answer."""
        message = await self._receive()
        if message["type"] == "http.disconnect" and not self._started:
            self._gone = True
        return message

    async def send(self, message: Message) -> None:
        """Pass ``message`` on, noting the answer's status."""
        if message["type"] == "http.response.start":
            self._started = True
            self.status = CLIENT_CLOSED if self._gone else int(message["status"])
        await self._send(message)


class RequestLogMiddleware:
    """ASGI middleware: request id in, request id out, one access line per request.

    Parameters
    ----------
    app
        The application it wraps.
    log
        Whether to write the access line (the id is handled either way).
    """

    def __init__(self, app: ASGIApp, log: bool = True) -> None:
        self.app = app
        self.log = log
        self.logger = logging.getLogger(ACCESS_LOGGER)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        request_id = _accepted_id(scope)
        scope.setdefault("state", {})["request_id"] = request_id
        token = _current.set(request_id)
        start = time.perf_counter()

        async def send_with_id(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = [(k, v) for k, v in message.get("headers", []) if k.lower() != _HEADER]
                headers.append((_HEADER, request_id.encode("ascii")))
                message = {**message, "headers": headers}
            await send(message)

        watch = AnswerWatch(receive, send_with_id)
        try:
            await self.app(scope, watch.receive, watch.send)
        finally:
            _current.reset(token)
            status = watch.status
            if self.log:
                duration_ms = (time.perf_counter() - start) * 1e3
                method, route = str(scope.get("method", "")), _route_of(scope)
                key_id = _key_id_of(scope)
                self.logger.info(
                    "%s %s %d %.1f ms request_id=%s key_id=%s", method, route, status,
                    duration_ms, request_id, key_id,
                    extra={"method": method, "route": route, "status": status,
                           "duration_ms": round(duration_ms, 3), "request_id": request_id,
                           "key_id": key_id})


class JsonFormatter(logging.Formatter):
    """One JSON object per record: time, level, logger, message, the request id and the
    extra fields given to the call (those of the access line)."""

    def format(self, record: logging.LogRecord) -> str:
        """Return ``record`` as one line of JSON."""
        entry: dict[str, Any] = {
            "time": datetime.fromtimestamp(record.created, UTC).isoformat(timespec="milliseconds"),
            "level": record.levelname.lower(),
            "logger": record.name,
            "message": record.getMessage(),
        }
        for name, value in vars(record).items():
            if name not in _STANDARD and not name.startswith("_"):
                entry[name] = value
        if "request_id" not in entry and (request_id := current_request_id()) is not None:
            entry["request_id"] = request_id
        if record.exc_info:
            entry["exception"] = self.formatException(record.exc_info)
        return json.dumps(entry, default=str)


class _TextFormatter(logging.Formatter):
    def format(self, record: logging.LogRecord) -> str:
        line = super().format(record)
        request_id = getattr(record, "request_id", None) or current_request_id()
        if request_id is not None and "request_id=" not in line:
            line = f"{line} request_id={request_id}"
        return line


_HANDLER_NAME = "hydrodiag-service"


class _StandardError(logging.StreamHandler):
    """A handler that writes to whatever ``sys.stderr`` is when a record is emitted, not
    the stream it was when logging was configured: a server thread that outlives a
    replaced (and closed) stream — a test's captured output — then
    neither fails with "I/O operation on closed file" nor loses the line."""

    @property
    def stream(self) -> TextIO:
        return sys.stderr

    @stream.setter
    def stream(self, _: object) -> None:  # set by StreamHandler.__init__; always stderr
        pass


def configure_logging(log_format: Literal["json", "text"], level: str) -> None:
    """Send the ``hydrodiag`` loggers to standard error in ``log_format`` at ``level``.

    Idempotent: a second call replaces the handler of the first.
    """
    root = logging.getLogger("hydrodiag")
    for handler in list(root.handlers):
        if handler.get_name() == _HANDLER_NAME:
            root.removeHandler(handler)
    handler = _StandardError()
    handler.set_name(_HANDLER_NAME)
    handler.setFormatter(JsonFormatter() if log_format == "json" else _TextFormatter(
        "%(asctime)s %(levelname)s %(name)s: %(message)s"))
    root.addHandler(handler)
    root.setLevel(level.upper())
    root.propagate = False
