"""Traffic of the load benchmark: closed-loop clients and an open-loop sender.

The requests are built as bytes before a phase starts (request line, headers, JSON body)
and sent on raw asyncio streams (HTTP/1.1, kept alive): on 2 cores the load generator
shares the CPU with the service, and an HTTP client library that builds, encodes and
parses each request in Python (httpx: ~1-2 ms of CPU per request) took CPU from the
service it measured.  Answers are read by their ``Content-Length`` (the service sends no
chunked answers); their bodies are kept for the store check after the phase.

A kept-alive connection is reused as an HTTP client library would (httpx's
``keepalive_expiry``, urllib3's dropped-connection check): not after the server closed it,
and not once it has been idle :data:`KEEPALIVE_EXPIRY_S`, below the service's keep-alive
(uvicorn's ``timeout_keep_alive``, 5 s), past which the server closes it and a request
sent on it meets an empty answer.  Without that the open loop, whose idle connections are
taken last-in first-out, reused a connection idle for longer and counted the server's
keep-alive close as a ``ConnectionError`` (1-3 per light ``make load-bench``).

Every function returns plain figures: latencies [ms] at p50/p99, errors, throughput [1/s].
"""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import Sequence
from typing import Any
from urllib.parse import urlsplit

import numpy as np

__all__ = ["Connection", "closed_loop", "open_loop", "request_bytes", "stats"]

TIMEOUT_S = 10.0
CLIENT_CONNECTIONS = 128
#: a connection idle this long is not reused [s] (the service closes it at 5 s)
KEEPALIVE_EXPIRY_S = 4.0


def stats(latencies: list[float], errors: int, elapsed: float) -> dict[str, float]:
    """p50, p99 [ms], count, errors and throughput [1/s] of ``latencies`` [s]."""
    lat = np.asarray(latencies) * 1e3
    return {
        "n": float(len(latencies) + errors), "errors": float(errors),
        "p50_ms": float(np.percentile(lat, 50)) if lat.size else float("nan"),
        "p99_ms": float(np.percentile(lat, 99)) if lat.size else float("nan"),
        "throughput_rps": len(latencies) / elapsed if elapsed > 0 else float("nan"),
    }


def request_bytes(base_url: str, method: str, path: str, body: Any = None,
                  headers: dict[str, str] | None = None) -> bytes:
    """One HTTP/1.1 request as sent on the wire (``body`` as JSON when given)."""
    host = urlsplit(base_url).netloc
    payload = b"" if body is None else json.dumps(body).encode()
    lines = [f"{method} {path} HTTP/1.1", f"Host: {host}", "Connection: keep-alive"]
    lines += [f"{k}: {v}" for k, v in (headers or {}).items()]
    if body is not None:
        lines += ["Content-Type: application/json", f"Content-Length: {len(payload)}"]
    return ("\r\n".join(lines) + "\r\n\r\n").encode() + payload


class Connection:
    """One kept-alive HTTP/1.1 connection; one request at a time."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._reader = reader
        self._writer = writer
        #: The server said ``Connection: close``: not to be used again.
        self.closing = False
        #: When its last answer came, or it opened [s, monotonic clock].
        self.idle_since = time.monotonic()

    @classmethod
    async def open(cls, base_url: str) -> Connection:
        """Connect to ``base_url`` (``http://host:port``)."""
        parts = urlsplit(base_url)
        reader, writer = await asyncio.open_connection(parts.hostname, parts.port)
        return cls(reader, writer)

    async def exchange(self, request: bytes) -> tuple[int, bytes]:
        """Send ``request``; return the answer's status and body.

        Raises
        ------
        ConnectionError
            The server closed the connection, or sent an answer without a length.
        """
        self._writer.write(request)
        status_line = await self._reader.readline()
        if not status_line:
            raise ConnectionError("the server closed the connection")
        status = int(status_line.split(b" ", 2)[1])
        length = None
        while True:
            line = await self._reader.readline()
            if line in (b"\r\n", b""):
                break
            name, _, value = line.partition(b":")
            name = name.strip().lower()
            if name == b"content-length":
                length = int(value)
            elif name == b"connection" and value.strip().lower() == b"close":
                self.closing = True
        if length is None:
            raise ConnectionError("an answer without Content-Length")
        body = await self._reader.readexactly(length)
        self.idle_since = time.monotonic()
        return status, body

    def reusable(self) -> bool:
        """Whether another request may be sent on it: the server neither said nor did close
        it, and it has been idle less than :data:`KEEPALIVE_EXPIRY_S`."""
        return (not self.closing and not self._reader.at_eof()
                and time.monotonic() - self.idle_since < KEEPALIVE_EXPIRY_S)

    def close(self) -> None:
        """Close the connection."""
        self._writer.close()


async def closed_loop(base_url: str, requests: Sequence[bytes], concurrency: int
                      ) -> dict[str, float]:
    """``concurrency`` clients send ``requests`` in turn, each after the previous answer."""
    latencies: list[float] = []
    errors = 0
    queue = list(reversed(requests))

    async def client() -> None:
        nonlocal errors
        connection: Connection | None = None
        while queue:
            request = queue.pop()
            start = time.perf_counter()
            try:
                if connection is not None and not connection.reusable():
                    connection.close()
                    connection = None
                if connection is None:
                    connection = await Connection.open(base_url)
                status, _ = await asyncio.wait_for(connection.exchange(request), TIMEOUT_S)
                ok = status == 200
            except (OSError, EOFError, TimeoutError, ValueError):
                ok = False
                if connection is not None:
                    connection.close()
                connection = None
            if ok:
                latencies.append(time.perf_counter() - start)
            else:
                errors += 1
        if connection is not None:
            connection.close()

    start = time.perf_counter()
    await asyncio.gather(*(client() for _ in range(concurrency)))
    return stats(latencies, errors, time.perf_counter() - start)


async def open_loop(base_url: str, requests: Sequence[bytes], rate: float, duration: float
                    ) -> dict[str, Any]:
    """Open one of ``requests`` every 1/``rate`` s for ``duration`` s, whatever the
    answers' pace, on at most :data:`CLIENT_CONNECTIONS` connections.

    ``"acknowledged"`` holds the bodies of the answers of 200 (to check them against the
    store); ``"connections"`` counts the connections opened.  Needs ``rate × duration``
    requests.  The liveness probe runs in a process of its own
    (:mod:`benchmarks.load_probe`).
    """
    total = round(rate * duration)
    if len(requests) < total:
        raise ValueError(f"{total} requests needed, {len(requests)} given")
    latencies: list[float] = []
    failures: dict[str, int] = {}
    acknowledged: list[bytes] = []
    in_flight = peak = opened = 0
    idle: list[Connection] = []
    slots = asyncio.Semaphore(CLIENT_CONNECTIONS)

    async def connect() -> Connection:
        """The last idle connection still reusable (the others closed), or a new one."""
        nonlocal opened
        while idle:
            connection = idle.pop()
            if connection.reusable():
                return connection
            connection.close()
        opened += 1
        return await Connection.open(base_url)

    async def exchange(request: bytes) -> tuple[int, bytes]:
        async with slots:
            connection = await connect()
            try:
                answer = await connection.exchange(request)
            except BaseException:
                connection.close()  # a broken or abandoned exchange: never reused
                raise
            if connection.closing:
                connection.close()
            else:
                idle.append(connection)
            return answer

    async def one(request: bytes) -> None:
        nonlocal in_flight, peak
        in_flight += 1
        peak = max(peak, in_flight)
        start = time.perf_counter()
        body = b""
        try:  # one deadline for the whole exchange, waiting for a connection included
            status, body = await asyncio.wait_for(exchange(request), TIMEOUT_S)
            reason = None if status == 200 else f"HTTP {status}"
        except TimeoutError:
            reason = "timeout"
        except (OSError, EOFError, ValueError) as exc:
            reason = type(exc).__name__
        in_flight -= 1
        if reason is None:
            latencies.append(time.perf_counter() - start)
            acknowledged.append(body)
        else:
            failures[reason] = failures.get(reason, 0) + 1

    start = time.perf_counter()
    tasks = []
    for i in range(total):
        delay = start + i / rate - time.perf_counter()
        if delay > 0:
            await asyncio.sleep(delay)
        tasks.append(asyncio.create_task(one(requests[i])))
    sending = time.perf_counter() - start
    await asyncio.gather(*tasks)
    elapsed = time.perf_counter() - start
    for connection in idle:
        connection.close()
    figures = stats(latencies, sum(failures.values()), elapsed)
    return figures | {"target_rps": rate, "duration_s": duration, "sent": float(total),
                      "send_rps": total / sending if sending > 0 else float("nan"),
                      "peak_in_flight": float(peak), "connections": float(opened),
                      "failures": failures,
                      "acknowledged": acknowledged}
