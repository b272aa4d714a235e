"""Traffic of the load benchmark: closed-loop clients and an open-loop sender.

The requests are built as bytes before a phase starts (request line, headers, JSON body)
and sent on raw asyncio streams (HTTP/1.1, kept alive): on 2 cores the load generator
shares the CPU with the service, and an HTTP client library that builds, encodes and
parses each request in Python (httpx: ~1-2 ms of CPU per request) took CPU from the
service it measured.  Answers are read by their ``Content-Length`` (the service sends no
chunked answers); their bodies are kept for the store check after the phase.

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
        return status, await self._reader.readexactly(length)

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
                if connection is None:
                    connection = await Connection.open(base_url)
                status, _ = await asyncio.wait_for(connection.exchange(request), TIMEOUT_S)
                ok = status == 200
                if connection.closing:
                    connection.close()
                    connection = None
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
    store).  Needs ``rate × duration`` requests.  The liveness probe runs in a process of
    its own (:mod:`benchmarks.load_probe`).
    """
    total = round(rate * duration)
    if len(requests) < total:
        raise ValueError(f"{total} requests needed, {len(requests)} given")
    latencies: list[float] = []
    failures: dict[str, int] = {}
    acknowledged: list[bytes] = []
    in_flight = peak = 0
    idle: list[Connection] = []
    slots = asyncio.Semaphore(CLIENT_CONNECTIONS)

    async def exchange(request: bytes) -> tuple[int, bytes]:
        async with slots:
            connection = idle.pop() if idle else await Connection.open(base_url)
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
                      "peak_in_flight": float(peak), "failures": failures,
                      "acknowledged": acknowledged}
