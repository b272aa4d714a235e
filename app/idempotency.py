"""``Idempotency-Key``: a write sent again after a timeout is answered, not done twice.

A client whose read timed out does not know whether its ``POST`` was stored, and sends it
again: without a key, a 40-record ``POST /diagnose`` left 80 rows, a resent series import
two series, a resent commissioning a second rig version fitted from the same records (an
operator pass).  A write (``POST``, ``PUT``, ``PATCH``, ``DELETE`` of the API, not the
console's forms) that carries ``Idempotency-Key: <1-255 visible ASCII characters>`` is
kept in the store under that key and the API key that sent it
(:class:`app.db.models.IdempotentRequest`, for :data:`KEEP_HOURS`; a request without an API
key stores nothing, and its header is ignored):

* the first request runs; once it succeeded (2xx) its status, content type, ``Location``
  and body are kept before the answer is sent, so an acknowledged answer is replayable
  (and a failed one frees its key before it is sent);
* the same request again (same method, path, query, content type and body) gets that
  answer, with ``Idempotent-Replayed: true``, and nothing runs or is stored;
* the same request while the first still runs: 409 ``ConflictError`` with ``Retry-After``
  (the usual case of a client that timed out); the first request marks its key every
  :data:`HEARTBEAT_S` while it runs, and one unmarked for :data:`STALE_S` (its process died,
  or the store was unreachable when it ended) no longer blocks the key;
* an answer is replayed only to a key that is still valid (a revoked one was answered for
  24 h), and the same JSON written otherwise (spacing, key order) is the same request;
* the store unreachable: 503 with ``Retry-After``, as any request then;
* another request under a used key: 422 ``InputError`` on ``Idempotency-Key``;
* a first request that failed (4xx, 5xx, an exception) leaves the key free: the retry runs.

The work and the key are marked in one transaction (:mod:`app.services.idempotent_work`):
``POST /diagnose`` keeps its whole answer in the transaction that stores its rows, so a
retry after the process died is replayed; any other write marks its key stored when it
commits, and a retry of a write stored whose answer was never kept (its process killed in
between) is refused, 409 ``ConflictError`` *without* ``Retry-After``, saying when it was
stored and to read the result back, instead of being done twice (an operator's kill -9
under load doubled 2 of ~4 requests in flight).  A key that died before its work was
stored blocks for :data:`STALE_S`, after which a retry runs.

The owner of a key is the API key's rotation chain (``api_keys.lineage_id``): a retry sent
with the key that replaced a rotated one (``hydrodiag keys rotate --grace``) is the same
client's retry.
"""

from __future__ import annotations

import asyncio
import functools
import hashlib
import json
import logging
import math
import re
from collections.abc import Callable, Sequence
from datetime import timedelta
from typing import Any

import anyio
from sqlalchemy import delete, select, update
from sqlalchemy.exc import IntegrityError, InterfaceError, OperationalError
from sqlalchemy.orm import Session
from starlette.requests import Request
from starlette.routing import BaseRoute, Match
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.db.base import utcnow
from app.db.models import IdempotentRequest
from app.errors import database_unavailable, response_for
from app.ratelimit import client_address
from app.schemas.times import iso_utc
from app.services.idempotent_work import CURRENT, KeyedWrite
from app.services.keys import authenticate
from sim.errors import AuthError, ConflictError, InputError

__all__ = ["HEADER", "HEARTBEAT_S", "IDEMPOTENT_METHODS", "KEEP_HOURS", "STALE_S",
           "IdempotencyMiddleware",
           "owner_of"]

logger = logging.getLogger("hydrodiag.app")

#: the request header
HEADER = "Idempotency-Key"
#: how long a key and its answer are kept [h]
KEEP_HOURS = 24
#: how often a running first request marks its key as still in hand [s]
HEARTBEAT_S = 10.0
#: after how long without that mark a first request no longer blocks its key (its process
#: died, or the store was unreachable when it failed) [s]
STALE_S = 30.0
#: seconds a retry of a request still running is asked to wait
RETRY_S = 2

_WRITES = frozenset({"POST", "PUT", "PATCH", "DELETE"})
#: the methods whose requests the header makes safe to retry (the document lists it on
#: each such operation)
IDEMPOTENT_METHODS = _WRITES
_VALID = re.compile(r"[\x21-\x7e]{1,255}")
#: (method, path) pairs whose route match a middleware keeps [-]
ROUTE_CACHE = 1024


def _header(scope: Scope, name: bytes) -> str | None:
    for k, v in scope.get("headers", []):
        if k.lower() == name:
            return bytes(v).decode("latin-1")
    return None


def _digest(*parts: bytes) -> str:
    h = hashlib.sha256()
    for part in parts:
        h.update(len(part).to_bytes(8, "big"))
        h.update(part)
    return h.hexdigest()


def owner_of(lineage_id: int) -> str:
    """The owner of the ``Idempotency-Key`` rows of the API keys of rotation chain
    ``lineage_id`` (the id of its first key)."""
    return _digest(f"key-lineage:{lineage_id}".encode())[:64]


def _canonical(content_type: str, body: bytes) -> tuple[str, bytes]:
    """The content type and body a retry must repeat: a multipart form's boundary left
    out (clients draw a new one for each send of the same form), a JSON body as its
    document (spacing and key order are the serialiser's)."""
    media, _, params = content_type.partition(";")
    if media.strip().lower() == "application/json":
        try:
            document = json.loads(body)
            canonical = json.dumps(document, sort_keys=True, separators=(",", ":")).encode()
        except (ValueError, RecursionError):
            # not JSON, or nested deeper than a parser goes (a 2 KB body 1,000 levels deep
            # was a 500 here): the route answers that, the bytes stand
            return content_type, body
        return "application/json", canonical
    match = re.search(r'boundary="?([^";]+)"?', params)
    if not media.strip().lower().startswith("multipart/") or match is None:
        return content_type, body
    return media.strip().lower(), body.replace(match.group(1).encode("latin-1"), b"-")


def _replaying(body: bytes, receive: Receive) -> Receive:
    """A ``receive`` that gives the body read already, then what ``receive`` gives."""
    sent = False

    async def replay() -> Message:
        nonlocal sent
        if not sent:
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return replay


class _UncheckedKeyError(Exception):
    """A key left unchecked: its client's address sent too many wrong keys
    (:data:`app.ratelimit.FAILED_KEYS_PER_MINUTE`); the route refuses it the same way."""


class _Outcome:
    """What the store says about a key: run it and keep the answer (``row_id``), answer
    ``response``, or neither (run it as a request without the header)."""

    def __init__(self, row_id: int | None = None, response: Any = None) -> None:
        self.row_id = row_id
        self.response = response


class IdempotencyMiddleware:
    """The ``Idempotency-Key`` handling of the API (module docstring).

    Parameters
    ----------
    app
        The application inside.
    sessions
        Session factory of the store.
    routes
        The application's routes: a key is handled only for a path and method an operation
        answers.
    """

    def __init__(self, app: ASGIApp, sessions: Callable[[], Session],
                 routes: Sequence[BaseRoute] = ()) -> None:
        self.app = app
        self.sessions = sessions
        self.routes = routes
        # the routes' match is ~70 µs a request; a keyed write meets few paths and methods
        self._answered = functools.lru_cache(maxsize=ROUTE_CACHE)(self._match)

    def _match(self, method: str, path: str) -> bool:
        scope = {"type": "http", "method": method, "path": path, "root_path": "",
                 "headers": [], "query_string": b""}
        return any(route.matches(scope)[0] == Match.FULL for route in self.routes)

    def _answered_by_an_operation(self, scope: Scope) -> bool:
        """Whether an operation of ``routes`` answers this path and method (every request,
        where no routes were given): a method the path does not take is the router's 405,
        not a key's 422 ("used for another request"; a fuzzer's PUT on POST /scenarios
        with a reused key)."""
        if not self.routes:
            return True
        return bool(self._answered(str(scope.get("method", "")), str(scope.get("path", ""))))

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        key = _header(scope, b"idempotency-key") if scope["type"] == "http" else None
        api_key = _header(scope, b"x-api-key") if key is not None else None
        path = str(scope.get("path", ""))
        # a request without an API key stores nothing (open reads), and anonymous clients
        # would share one owner: their keys are not kept
        if (key is None or not api_key or scope.get("method") not in _WRITES
                or path.startswith("/console") or not self._answered_by_an_operation(scope)):
            await self.app(scope, receive, send)
            return
        if not _VALID.fullmatch(key):
            await response_for(InputError(f"the {HEADER} header must be 1 to 255 visible "
                                          "ASCII characters", field=HEADER),
                               request=Request(scope))(scope, receive, send)
            return
        chunks: list[bytes] = []
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return
            chunks.append(message.get("body", b""))
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        content_type, same_body = _canonical(_header(scope, b"content-type") or "", body)
        digest = _digest(str(scope["method"]).encode(), path.encode(),
                         bytes(scope.get("query_string", b"")), content_type.encode(),
                         same_body)
        try:
            outcome = await anyio.to_thread.run_sync(self._claim, key, str(scope["method"]),
                                                     path, digest, Request(scope), api_key)
        except (OperationalError, InterfaceError) as exc:   # the store does not answer
            await database_unavailable(Request(scope), exc)(scope, receive, send)
            return
        if outcome.response is not None:
            await outcome.response(scope, receive, send)
            return
        if outcome.row_id is None:   # not kept (a key no longer valid): as without header
            await self._app_with_body(scope, receive, send, body)
            return
        beat = asyncio.ensure_future(self._heartbeat(outcome.row_id))
        try:
            await self._run(scope, receive, send, body, outcome.row_id)
        finally:
            beat.cancel()

    async def _app_with_body(self, scope: Scope, receive: Receive, send: Send,
                             body: bytes) -> None:
        await self.app(scope, _replaying(body, receive), send)

    async def _heartbeat(self, row_id: int) -> None:
        while True:
            await asyncio.sleep(HEARTBEAT_S)
            try:
                await anyio.to_thread.run_sync(self._touch, row_id)
            except Exception as exc:  # the store away for a while: the key goes stale
                logger.warning("could not mark an %s in hand: %s", HEADER, type(exc).__name__)

    async def _run(self, scope: Scope, receive: Receive, send: Send, body: bytes,
                   row_id: int) -> None:
        start: Message | None = None
        parts: list[bytes] = []
        keyed = KeyedWrite(row_id)
        token = CURRENT.set(keyed)   # the work marks its key in its own transaction

        async def capture(message: Message) -> None:
            # every answer is held until the key is settled: a failure passed on as it came
            # let the client's retry arrive before its key was freed (422, another request)
            nonlocal start
            if message["type"] == "http.response.start":
                start = message
            elif message["type"] == "http.response.body":
                parts.append(message.get("body", b""))

        try:
            await self.app(scope, _replaying(body, receive), capture)
        except BaseException:
            await self._settle(self._release, row_id)
            raise
        finally:
            CURRENT.reset(token)
        assert start is not None
        content = b"".join(parts)
        if start["status"] // 100 != 2:
            await self._settle(self._release, row_id)
            await send(start)
            await send({"type": "http.response.body", "body": content, "more_body": False})
            return
        headers = {k.lower(): v for k, v in start.get("headers", [])}
        if not keyed.kept:   # POST /diagnose kept it with its rows
            await self._settle(self._keep, row_id, int(start["status"]),
                               headers.get(b"content-type", b"").decode("latin-1") or None,
                               headers.get(b"location", b"").decode("latin-1") or None,
                               content)
        await send(start)
        await send({"type": "http.response.body", "body": content, "more_body": False})

    async def _settle(self, step: Callable[..., None], *args: Any) -> None:
        """Release or keep a key; a store that does not answer leaves it to go stale
        (:data:`STALE_S`) rather than turning the answer into an error."""
        try:
            await anyio.to_thread.run_sync(step, *args)
        except (OperationalError, InterfaceError) as exc:
            logger.warning("could not settle an %s (%s): it frees itself in %.0f s", HEADER,
                           type(exc).__name__, STALE_S)

    # -- the store (run in a worker thread) --------------------------------------------
    def _claim(self, key: str, method: str, path: str, digest: str, request: Request,
               api_key: str) -> _Outcome:
        now = utcnow()
        limiter = getattr(request.app.state, "failed_keys", None)
        client = client_address(request)

        def guard() -> None:   # a key not verified before, from an address over its bound
            if limiter is not None and limiter.wait_for(client) > 0:
                raise _UncheckedKeyError

        with self.sessions() as session:
            try:   # the owner: the key's rotation chain (module docstring)
                sender = authenticate(session, api_key, before_check=guard)
            except (AuthError, _UncheckedKeyError):   # the route answers 401 (429); nothing kept
                return _Outcome()
            owner = owner_of(sender.lineage_id or sender.id)
            session.execute(delete(IdempotentRequest)
                            .where(IdempotentRequest.expires_at < now))
            session.commit()
            row = IdempotentRequest(owner=owner, idempotency_key=key, method=method,
                                    path=path, digest=digest, created_at=now, touched_at=now,
                                    expires_at=now + timedelta(hours=KEEP_HOURS))
            session.add(row)
            try:
                session.commit()
                return _Outcome(row_id=row.id)
            except IntegrityError:
                session.rollback()
            found = session.scalar(select(IdempotentRequest).where(
                IdempotentRequest.owner == owner, IdempotentRequest.idempotency_key == key))
            if found is None:  # released meanwhile: try once more
                return self._claim(key, method, path, digest, request, api_key)
            if found.digest != digest:
                return _Outcome(response=response_for(InputError(
                    f"this {HEADER} was used for another request ({found.method} "
                    f"{found.path}, or other content) in the last {KEEP_HOURS} h: a retry "
                    "must send the same request; a new request needs a new key",
                    field=HEADER), request=request))
            if found.status is not None:   # (to a key still valid: checked above)
                logger.info("replayed the answer of %s %s under an %s", method, path, HEADER)
                headers = {"Idempotent-Replayed": "true"}
                if found.location:
                    headers["Location"] = found.location
                return _Outcome(response=_Stored(found.status, found.content_type,
                                                 found.body or b"", headers))
            if found.stored_at is not None and found.touched_at <= now - timedelta(
                    seconds=STALE_S):
                # stored, and its process died before the answer was kept: not run again
                return _Outcome(response=response_for(ConflictError(
                    f"the first request with this {HEADER} was done and stored at "
                    f"{iso_utc(found.stored_at)}, but the service "
                    "stopped before its answer was kept; it is not done again: read what it "
                    f"stored back ({found.method} {found.path}: the listing of what it "
                    "writes)", field=HEADER), request=request))
            if found.touched_at > now - timedelta(seconds=STALE_S):
                quiet = (now - found.touched_at).total_seconds()
                if quiet <= HEARTBEAT_S + RETRY_S:
                    return _Outcome(response=response_for(ConflictError(
                        f"the first request with this {HEADER} is still being processed; "
                        f"retry in {RETRY_S} s to get its answer", field=HEADER),
                        headers={"Retry-After": str(RETRY_S)}, request=request))
                # no mark for longer than a heartbeat: its process has most likely
                # stopped (a restart); the key frees itself when it goes stale (a client
                # told "still being processed, retry in 2 s" retried 15 times; an
                # operator pass)
                left = max(math.ceil(STALE_S - quiet), 1)
                return _Outcome(response=response_for(ConflictError(
                    f"the first request with this {HEADER} was not marked in hand for "
                    f"{quiet:.0f} s: the process running it has most likely stopped; the key "
                    f"frees itself {STALE_S:.0f} s after its last mark, in {left} s, and a "
                    "retry then runs it (unless its work was stored)", field=HEADER),
                    headers={"Retry-After": str(left)}, request=request))
            # its process never finished it: the key is taken over
            found.created_at = found.touched_at = now
            found.expires_at = now + timedelta(hours=KEEP_HOURS)
            session.commit()
            return _Outcome(row_id=found.id)

    def _touch(self, row_id: int) -> None:
        with self.sessions() as session:
            session.execute(update(IdempotentRequest).where(IdempotentRequest.id == row_id)
                            .values(touched_at=utcnow()))
            session.commit()

    def _release(self, row_id: int | None) -> None:
        with self.sessions() as session:
            session.execute(delete(IdempotentRequest).where(IdempotentRequest.id == row_id))
            session.commit()

    def _keep(self, row_id: int | None, status: int, content_type: str | None,
              location: str | None, body: bytes) -> None:
        with self.sessions() as session:
            row = session.get(IdempotentRequest, row_id)
            if row is None:  # pragma: no cover - expired under a request of a day
                return
            row.status, row.content_type, row.location, row.body = (
                status, content_type, location, body)
            session.commit()


class _Stored:
    """A kept answer, sent again (an ASGI app)."""

    def __init__(self, status: int, content_type: str | None, body: bytes,
                 headers: dict[str, str]) -> None:
        self.status, self.body = status, body
        self.headers = [(k.lower().encode("latin-1"), v.encode("latin-1"))
                        for k, v in headers.items()]
        if content_type:
            self.headers.append((b"content-type", content_type.encode("latin-1")))
        self.headers.append((b"content-length", str(len(body)).encode()))

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        await send({"type": "http.response.start", "status": self.status,
                    "headers": self.headers})
        await send({"type": "http.response.body", "body": self.body, "more_body": False})
