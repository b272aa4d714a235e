"""uvicorn's HTTP/1.1 protocol with ``TCP_NODELAY`` on every accepted connection.

With several workers uvicorn binds the listening socket itself (``Config.bind_socket``)
with protocol number 0, and asyncio sets ``TCP_NODELAY`` only on sockets whose protocol is
``IPPROTO_TCP``.  Without it a kept-alive client's next request meets Nagle's algorithm
against the client's delayed ACK: every answer after the first took 40-44 ms instead of
under 1 ms (``GET /health`` measured with ``HYDRODIAG_WORKERS=2``).  ``serve`` passes this
class as uvicorn's ``http`` protocol in both the single- and multi-worker cases:
:class:`NoDelayHttpToolsProtocol` (uvicorn's parser in C, ``httptools``);
:class:`NoDelayH11Protocol` is the pure-Python one it used before.  The pure
Python parser and its per-event objects were a fifth of the server process's CPU per
``POST /diagnose`` once the diagnosis had left it (profile of issue 9).
"""

from __future__ import annotations

import asyncio
import socket

from uvicorn.protocols.http.h11_impl import H11Protocol
from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

__all__ = ["BODY_GRACE_S", "FIRST_REQUEST_S", "MIN_BODY_RATE", "NoDelayH11Protocol",
           "NoDelayHttpToolsProtocol", "set_nodelay"]

#: a connection that sends nothing this long after it opens is closed [s]: uvicorn closes an
#: idle kept-alive connection after ``timeout_keep_alive``, but one that never sends a
#: request held its file descriptor for ever, and 600 of them left /health unanswered at
#: the open-file limit, no key needed (an SRE pass)
FIRST_REQUEST_S = 10.0
#: a request's body may take this long [s] ...
BODY_GRACE_S = 10.0
#: ... plus what of it has come at this rate [bytes/s]: past that the connection is closed,
#: so a body must keep coming at 4 KiB/s on average after its first 10 s (a 32 kbit/s field
#: link does).  A body sent a byte a second held its connection and worker task for as long
#: as the client liked (an SRE pass left it to a proxy); counting the length it declared
#: instead of what came still let one hold it 34 min on an 8 MB Content-Length (a
#: verification pass).  The time the service itself does not read (its buffer full, a
#: ``100 Continue`` not yet sent) does not count.
MIN_BODY_RATE = 4096.0


def set_nodelay(transport: asyncio.BaseTransport) -> bool:
    """Switch Nagle's algorithm off on ``transport``'s TCP socket; whether it was set."""
    sock = transport.get_extra_info("socket")
    if sock is None or sock.family not in (socket.AF_INET, socket.AF_INET6):
        return False
    try:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    except OSError:  # a socket already closed by the peer
        return False
    return True


def _first_request_timer(protocol: H11Protocol | HttpToolsProtocol) -> None:
    """Close the connection unless its first bytes come within :data:`FIRST_REQUEST_S`:
    uvicorn's keep-alive timer, which its ``data_received`` cancels, started at once."""
    protocol.timeout_keep_alive_task = protocol.loop.call_later(
        FIRST_REQUEST_S, protocol.timeout_keep_alive_handler)


class NoDelayH11Protocol(H11Protocol):
    """:class:`~uvicorn.protocols.http.h11_impl.H11Protocol` with ``TCP_NODELAY`` set and
    a silent connection closed (:data:`FIRST_REQUEST_S`)."""

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        set_nodelay(transport)
        super().connection_made(transport)  # type: ignore[arg-type]
        _first_request_timer(self)



class NoDelayHttpToolsProtocol(HttpToolsProtocol):
    """uvicorn's ``httptools`` protocol (its parser in C) with ``TCP_NODELAY`` set, and a
    connection closed whose request's head (its line and headers) has not all come
    :data:`FIRST_REQUEST_S` after the connection opened or the request began: a silent
    connection, and one that sent a byte or half a header and stopped (600 of those still
    held every descriptor until /health failed: a verification pass); and one whose body
    comes slower than :data:`MIN_BODY_RATE` on average after :data:`BODY_GRACE_S`."""

    _head_due: asyncio.TimerHandle | None = None
    _body_due: asyncio.TimerHandle | None = None
    #: loop time the body's clock started (moved on by the waits that are the service's)
    _body_started = 0.0
    _body_checked = 0.0
    _body_length = 0
    _body_received = 0

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        set_nodelay(transport)
        super().connection_made(transport)  # type: ignore[arg-type]
        self._await_head()

    def _await_head(self) -> None:
        if self._head_due is not None:
            self._head_due.cancel()
        self._head_due = self.loop.call_later(FIRST_REQUEST_S, self._head_late)

    def _head_late(self) -> None:
        self._head_due = None
        if not self.transport.is_closing():
            self.transport.close()

    def on_message_begin(self) -> None:
        super().on_message_begin()
        self._await_head()

    def on_headers_complete(self) -> None:
        if self._head_due is not None:
            self._head_due.cancel()
            self._head_due = None
        super().on_headers_complete()
        # a request without a body completes at once and cancels this (on_message_complete)
        self._stop_body_clock()
        if self.transport.is_closing() or self.parser.should_upgrade():
            return
        length = dict(self.headers).get(b"content-length", b"0")
        self._body_length = int(length) if length.isdigit() else 0
        self._body_received = 0
        self._body_started = self._body_checked = self.loop.time()
        self._body_due = self.loop.call_at(self._body_deadline(), self._body_check)

    def on_body(self, body: bytes) -> None:
        self._body_received += len(body)
        super().on_body(body)

    def on_message_complete(self) -> None:
        self._stop_body_clock()
        super().on_message_complete()

    def _body_deadline(self) -> float:
        """When more of the body must have come [loop time]: what came buys time at
        :data:`MIN_BODY_RATE`, what was declared does not."""
        return self._body_started + BODY_GRACE_S + self._body_received / MIN_BODY_RATE

    def _body_check(self) -> None:
        self._body_due = None
        now = self.loop.time()
        cycle = self.cycle
        if self.flow.read_paused or (cycle is not None and cycle.waiting_for_100_continue):
            # the service is not reading: its wait is not the client's
            self._body_started += now - self._body_checked
            self._body_checked = now
            self._body_due = self.loop.call_at(now + 1.0, self._body_check)
            return
        self._body_checked = now
        due = self._body_deadline()
        if now < due:
            self._body_due = self.loop.call_at(due, self._body_check)
        elif not self.transport.is_closing():
            self.logger.warning(
                "closed a connection whose request body came too slowly: %d of %s bytes "
                "in %.0f s", self._body_received, self._body_length or "?",
                now - self._body_started)
            self.transport.close()

    def _stop_body_clock(self) -> None:
        if self._body_due is not None:
            self._body_due.cancel()
            self._body_due = None

    def connection_lost(self, exc: Exception | None) -> None:
        if self._head_due is not None:
            self._head_due.cancel()
            self._head_due = None
        self._stop_body_clock()
        super().connection_lost(exc)
