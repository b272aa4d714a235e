"""Limits on the work one request may ask for: body size, batch length, sweep size.

Each limit is a setting (:class:`app.settings.Settings`, ``HYDRODIAG_...``) with a documented
default; a request over it is answered 413 (body) or 422 (``InputError``) with a message
that names the limit and its setting.  The schemas carry fixed *ceilings*
(:data:`BATCH_RECORDS_CEILING`, ...): the most a setting may be raised to, and what bounds
the work of parsing before the setting is checked.

Request body size limit, checked before anything parses the body.

:class:`BodyLimitMiddleware` answers 413 (``PayloadTooLargeError``, naming the limit) when
the ``Content-Length`` header is over ``max_body_bytes``, and otherwise reads the body as it
arrives, stopping at the limit, before the application sees it: a 50 MB body (or one sent
in chunks without a length) costs at most the limit in memory, and no JSON parser runs on
it.
"""

from __future__ import annotations

import json
from typing import Any

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.errors import PayloadTooLargeError
from app.logs import request_id_of
from sim.errors import InputError

__all__ = [
    "BATCH_RECORDS_CEILING",
    "DEFAULT_SWEEP_POINTS",
    "SWEEP_POINTS_CEILING",
    "BodyLimitMiddleware",
    "check_count",
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


class BodyLimitMiddleware:
    """ASGI middleware refusing request bodies over ``limit`` bytes with a 413.

    Parameters
    ----------
    app
        The application it wraps.
    limit
        Largest body accepted [byte].
    """

    def __init__(self, app: ASGIApp, limit: int) -> None:
        self.app = app
        self.limit = limit

    async def _refuse(self, scope: Scope, send: Send) -> None:
        error: dict[str, Any] = {
            "type": PayloadTooLargeError.__name__,
            "message": f"the request body is larger than the limit of {self.limit} bytes "
                       "(setting HYDRODIAG_MAX_BODY_BYTES)",
            "field": "body",
        }
        if (request_id := request_id_of(scope)) is not None:
            error["request_id"] = request_id
        body = json.dumps({"error": error}).encode("utf-8")
        await send({"type": "http.response.start", "status": 413, "headers": [
            (b"content-type", b"application/json"),
            (b"content-length", str(len(body)).encode("ascii")),
            (b"connection", b"close"),
        ]})
        await send({"type": "http.response.body", "body": body})

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = dict(scope.get("headers") or []).get(b"content-length")
        if declared is not None:
            try:
                too_large = int(declared) > self.limit
            except ValueError:
                too_large = False  # the server refuses a malformed length itself
            if too_large:
                await self._refuse(scope, send)
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
            if size > self.limit:
                await self._refuse(scope, send)
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
