"""The pipes between a server process and its diagnosis processes, as the event loop reads
them (:class:`app.services.diagnosis_pool.DiagnosisPool`).

Messages are framed as :meth:`multiprocessing.connection.Connection.send_bytes` frames
them, so that a diagnosis process reads its end with ``recv_bytes``; the server reads its
end from the event loop without blocking (uvloop makes the descriptor non-blocking): what
is there is appended to a buffer, and whole messages are taken from it.
"""

from __future__ import annotations

import asyncio
import os
import struct
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any

__all__ = ["READ_CHUNK", "Process", "Queued", "send_whole", "take_message"]

#: Most bytes read from a pipe at once [byte].
READ_CHUNK = 1 << 20


def take_message(buffer: bytearray) -> bytes | None:
    """Remove and return the first whole message of ``buffer``, framed as
    :meth:`multiprocessing.connection.Connection.send_bytes` frames it (a signed 4-byte
    big-endian length, or -1 then an 8-byte length); ``None`` while it is incomplete."""
    if len(buffer) < 4:
        return None
    (size,) = struct.unpack_from("!i", buffer)
    start = 4
    if size == -1:
        if len(buffer) < 12:
            return None
        (size,) = struct.unpack_from("!Q", buffer, 4)
        start = 12
    if len(buffer) < start + size:
        return None
    message = bytes(buffer[start:start + size])
    del buffer[:start + size]
    return message


def send_whole(connection: Connection, message: bytes) -> None:
    """Send ``message`` whole, the descriptor blocking meanwhile (the process at the other
    end is idle, reading; uvloop leaves the descriptor non-blocking)."""
    fd = connection.fileno()
    blocking = os.get_blocking(fd)
    os.set_blocking(fd, True)
    try:
        connection.send_bytes(message)
    finally:
        os.set_blocking(fd, blocking)


@dataclass(eq=False)
class Process:
    """One diagnosis process, its pipe, and the task it is computing."""

    process: BaseProcess
    connection: Connection
    ready: bool = False
    pid: int | None = None
    waiter: asyncio.Future[Any] | None = None
    sent_at: float = 0.0
    buffer: bytearray = field(default_factory=bytearray)
    done: int = 0


@dataclass
class Queued:
    """A task waiting for a free diagnosis process: its pickled message, its answer."""

    message: bytes
    future: asyncio.Future[Any] = field(repr=False)
    #: When it was queued [s, ``time.perf_counter``].
    queued_at: float = 0.0
