"""Limits on the work one request may ask for: body size, batch length, sweep size.

Each limit is a setting (:class:`app.settings.Settings`, ``HYDRODIAG_...``) with a documented
default; a request over it is answered 413 (body) or 422 (``InputError``) with a message
that names the limit and its setting.  The schemas carry fixed *ceilings*
(:data:`BATCH_RECORDS_CEILING`, ...): the most a setting may be raised to, and what bounds
the work of parsing before the setting is checked.

Request body size limit, checked before anything parses the body.

:class:`BodyLimitMiddleware` answers 413 (``PayloadTooLargeError``, naming the limit) when
the ``Content-Length`` header is over the limit, and otherwise reads the body as it
arrives, stopping at the limit, before the application sees it: a 50 MB body (or one sent
in chunks without a length) costs at most the limit in memory, and no JSON parser runs on
it.  The limit is ``max_body_bytes`` (8 MiB) for every body but a file upload
(``multipart/form-data``), which has ``max_upload_bytes`` (64 MiB): the upload routes take
files larger than any JSON document (a measured series up to 20 MiB, a discrepancy data
file up to 50 MiB) and cap their file themselves.
"""

from __future__ import annotations

from starlette.requests import Request
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.errors import PayloadTooLargeError, response_for
from sim.errors import InputError

__all__ = [
    "BATCH_RECORDS_CEILING",
    "DEFAULT_SWEEP_POINTS",
    "SWEEP_POINTS_CEILING",
    "BodyLimitMiddleware",
    "check_count",
    "check_file",
]

#: Most records one ``/diagnose`` may carry whatever the settings say [-].
BATCH_RECORDS_CEILING = 10_000
#: Most points one sweep may run whatever the settings say, per method [-].
SWEEP_POINTS_CEILING = {"steady": 100_000, "transient": 10_000}
#: Default most points of one sweep, per method [-] (a transient point costs ~100 steady).
DEFAULT_SWEEP_POINTS = {"steady": 5000, "transient": 200}


def check_count(count: int, limit: int, *, what: str, field: str, setting: str) -> None:
    """Refuse ``count`` items over ``limit`` with a 422 naming the limit and its setting.

    Parameters
    ----------
    count
        How many items the request asks for [-].
    limit
        Most allowed [-].
    what
        What is counted, plural (``"records"``), for the message.
    field
        The request field that holds them.
    setting
        Name of the setting's attribute (``max_batch_records``); the message gives its
        environment variable.

    Raises
    ------
    InputError
        ``count`` is over ``limit``.
    """
    if count > limit:
        raise InputError(f"{count} {what}; at most {limit} per request "
                         f"(setting HYDRODIAG_{setting.upper()})", field=field)


def check_file(content: bytes, limit: int, *, field: str = "file") -> None:
    """Refuse an uploaded file over ``limit`` bytes, or an empty one, with a 422 on ``field``.

    The routes read at most ``limit + 1`` bytes of an upload, so a file over the limit is
    said to be larger than it, not given a size it does not have.

    Parameters
    ----------
    content
        The file's bytes as read (at most ``limit + 1`` of them) [-].
    limit
        Largest file accepted [byte].
    field
        The form field that holds the file.

    Raises
    ------
    InputError
        The file is over ``limit`` bytes, or holds only white space.
    """
    if len(content) > limit:
        raise InputError(f"the file is larger than {limit} bytes ({limit / 2**20:g} MiB), "
                         "the most this operation reads", field=field)
    if not content.strip():
        raise InputError("the file is empty", field=field)


class BodyLimitMiddleware:
    """ASGI middleware refusing request bodies over their limit with a 413.

    Parameters
    ----------
    app
        The application it wraps.
    limit
        Largest body accepted [byte] (setting ``max_body_bytes``).
    upload_limit
        Largest ``multipart/form-data`` body accepted [byte] (setting
        ``max_upload_bytes``); ``limit`` when not given.
    """

    def __init__(self, app: ASGIApp, limit: int, upload_limit: int | None = None) -> None:
        self.app = app
        self.limit = limit
        self.upload_limit = limit if upload_limit is None else upload_limit

    def _limit_of(self, headers: dict[bytes, bytes]) -> tuple[int, str]:
        """The limit [byte] that applies to a request with ``headers``, and its setting."""
        kind = headers.get(b"content-type", b"").split(b";", 1)[0].strip().lower()
        if kind == b"multipart/form-data":
            return self.upload_limit, "HYDRODIAG_MAX_UPLOAD_BYTES"
        return self.limit, "HYDRODIAG_MAX_BODY_BYTES"

    async def _refuse(self, scope: Scope, receive: Receive, send: Send, limit: int,
                      setting: str) -> None:
        # the error tree's answer (app.errors.response_for), the connection closed: the
        # rest of the body is not read
        response = response_for(PayloadTooLargeError(
            f"the request body is larger than the limit of {limit} bytes (setting "
            f"{setting})", field="body"), request=Request(scope))
        response.headers["connection"] = "close"
        await response(scope, receive, send)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or [])
        limit, setting = self._limit_of(headers)
        declared = headers.get(b"content-length")
        if declared is not None:
            try:
                too_large = int(declared) > limit
            except ValueError:
                too_large = False  # the server refuses a malformed length itself
            if too_large:
                await self._refuse(scope, receive, send, limit, setting)
                return
        if scope.get("method") in {"GET", "HEAD", "OPTIONS"} and declared is None:
            await self.app(scope, receive, send)
            return
        chunks: list[bytes] = []
        size = 0
        while True:
            message = await receive()
            if message["type"] != "http.request":  # the client went away
                await self.app(scope, _replay([message], receive), send)
                return
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > limit:
                await self._refuse(scope, receive, send, limit, setting)
                return
            chunks.append(chunk)
            if not message.get("more_body", False):
                break
        whole: Message = {"type": "http.request", "body": b"".join(chunks), "more_body": False}
        await self.app(scope, _replay([whole], receive), send)


def _replay(messages: list[Message], receive: Receive) -> Receive:
    """A ``receive`` that first returns ``messages``, then waits on the real one."""
    pending = list(messages)

    async def replay() -> Message:
        if pending:
            return pending.pop(0)
        return await receive()

    return replay
