"""Traffic of the load benchmark: closed-loop clients and an open-loop sender.

Every function takes a ``send`` coroutine (one request on a given ``httpx.AsyncClient``)
and returns plain figures: latencies [ms] at p50/p99, errors, throughput [1/s].
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable
from typing import Any

import httpx
import numpy as np

__all__ = ["Send", "closed_loop", "open_loop", "stats"]

TIMEOUT_S = 10.0
CLIENT_CONNECTIONS = 128

Send = Callable[[httpx.AsyncClient], Awaitable[httpx.Response]]


def stats(latencies: list[float], errors: int, elapsed: float) -> dict[str, float]:
    """p50, p99 [ms], count, errors and throughput [1/s] of ``latencies`` [s]."""
    lat = np.asarray(latencies) * 1e3
    return {
        "n": float(len(latencies) + errors), "errors": float(errors),
        "p50_ms": float(np.percentile(lat, 50)) if lat.size else float("nan"),
        "p99_ms": float(np.percentile(lat, 99)) if lat.size else float("nan"),
        "throughput_rps": len(latencies) / elapsed if elapsed > 0 else float("nan"),
    }


async def closed_loop(base_url: str, send: Send, n: int, concurrency: int) -> dict[str, float]:
    """``concurrency`` clients send ``n`` requests in all, each after the previous answer."""
    latencies: list[float] = []
    errors = 0
    remaining = n

    async def client(http: httpx.AsyncClient) -> None:
        nonlocal remaining, errors
        while remaining > 0:
            remaining -= 1
            start = time.perf_counter()
            try:
                response = await send(http)
                ok = response.status_code == 200
            except httpx.HTTPError:
                ok = False
            if ok:
                latencies.append(time.perf_counter() - start)
            else:
                errors += 1

    limits = httpx.Limits(max_connections=concurrency, max_keepalive_connections=concurrency)
    async with httpx.AsyncClient(base_url=base_url, timeout=TIMEOUT_S, limits=limits) as http:
        start = time.perf_counter()
        await asyncio.gather(*(client(http) for _ in range(concurrency)))
        elapsed = time.perf_counter() - start
    return stats(latencies, errors, elapsed)


async def open_loop(base_url: str, send: Send, rate: float, duration: float
                    ) -> dict[str, Any]:
    """Open a request every 1/``rate`` s for ``duration`` s, whatever the answers' pace.

    ``"acknowledged"`` holds the answers of 200 (to check them against the store).  The
    liveness probe runs in a process of its own (:mod:`benchmarks.load_probe`).
    """
    latencies: list[float] = []
    failures: dict[str, int] = {}
    acknowledged: list[httpx.Response] = []
    in_flight = peak = 0
    slots = asyncio.Semaphore(CLIENT_CONNECTIONS)

    async def exchange(http: httpx.AsyncClient) -> httpx.Response:
        async with slots:  # O(1) queueing here; httpcore's pool is slow with long queues
            return await send(http)

    async def one(http: httpx.AsyncClient) -> None:
        nonlocal in_flight, peak
        in_flight += 1
        peak = max(peak, in_flight)
        start = time.perf_counter()
        try:  # one deadline for the whole exchange, waiting for a connection included
            response = await asyncio.wait_for(exchange(http), TIMEOUT_S)
            reason = None if response.status_code == 200 else f"HTTP {response.status_code}"
        except (TimeoutError, httpx.TimeoutException):
            reason = "timeout"
        except httpx.HTTPError as exc:
            reason = type(exc).__name__
        in_flight -= 1
        if reason is None:
            latencies.append(time.perf_counter() - start)
            acknowledged.append(response)
        else:
            failures[reason] = failures.get(reason, 0) + 1

    total = round(rate * duration)
    limits = httpx.Limits(max_connections=CLIENT_CONNECTIONS,
                          max_keepalive_connections=CLIENT_CONNECTIONS)
    async with httpx.AsyncClient(base_url=base_url, timeout=TIMEOUT_S, limits=limits) as http:
        start = time.perf_counter()
        tasks = []
        for i in range(total):
            delay = start + i / rate - time.perf_counter()
            if delay > 0:
                await asyncio.sleep(delay)
            tasks.append(asyncio.create_task(one(http)))
        sending = time.perf_counter() - start
        await asyncio.gather(*tasks)
        elapsed = time.perf_counter() - start
    figures = stats(latencies, sum(failures.values()), elapsed)
    return figures | {"target_rps": rate, "duration_s": duration, "sent": float(total),
                      "send_rps": total / sending if sending > 0 else float("nan"),
                      "peak_in_flight": float(peak), "failures": failures,
                      "acknowledged": acknowledged}
