"""Requests per API key and minute: a token bucket per key, in each server process.

The same buckets, per client address, bound the wrong API keys a client may try
(:data:`FAILED_KEYS_PER_MINUTE`): each costs a key derivation (scrypt, ~13 ms of CPU), and
a client sending wrong secrets could keep both cores of a small server busy (an operator
pass); over the bound, a key this process has not verified before is answered 429
without being checked.

With ``HYDRODIAG_RATE_LIMIT_PER_MINUTE=N`` (default 0: no limit) each key may send ``N``
requests in a burst and then ``N`` per minute; a request over that is answered 429 with
``Retry-After`` (whole seconds until a request would be accepted).  Each worker process
keeps its own buckets, so with ``W`` workers a key gets up to ``W × N``.
"""

from __future__ import annotations

import math
import threading
import time
from collections import OrderedDict

from starlette.requests import Request

__all__ = ["FAILED_KEYS_PER_MINUTE", "KeyRateLimiter", "client_address"]

#: Wrong API keys a client address may send per minute (and in a burst) before the keys it
#: sends that this process has not verified before are refused unchecked [1/min].
FAILED_KEYS_PER_MINUTE = 30


def client_address(request: Request) -> str:
    """The address whose wrong keys are counted ("-" when the server does not know it)."""
    return request.client.host if request.client is not None else "-"


class KeyRateLimiter:
    """Token buckets per key.

    Parameters
    ----------
    per_minute
        Requests a key may send per minute, and the size of its burst [1/min].
    max_keys
        Buckets kept [-]; the least recently used are dropped (a dropped key starts full).
    """

    def __init__(self, per_minute: int, max_keys: int = 10_000) -> None:
        if per_minute < 1:
            raise ValueError("per_minute must be at least 1")
        self.capacity = float(per_minute)
        self.rate = per_minute / 60.0  # tokens per second
        self._buckets: OrderedDict[str, tuple[float, float]] = OrderedDict()
        self._max_keys = max_keys
        self._lock = threading.Lock()

    def acquire(self, key: str, now: float | None = None) -> float:
        """Take one token for ``key``; return 0 if granted, else the wait [s] for one."""
        now = time.monotonic() if now is None else now
        with self._lock:
            tokens, stamp = self._buckets.pop(key, (self.capacity, now))
            tokens = min(self.capacity, tokens + (now - stamp) * self.rate)
            wait = 0.0
            if tokens >= 1.0:
                tokens -= 1.0
            else:
                wait = (1.0 - tokens) / self.rate
            self._buckets[key] = (tokens, now)
            while len(self._buckets) > self._max_keys:
                self._buckets.popitem(last=False)
            return wait

    def wait_for(self, key: str, now: float | None = None) -> float:
        """The wait [s] before ``key`` has a token, without taking one (0: it has)."""
        now = time.monotonic() if now is None else now
        with self._lock:
            tokens, stamp = self._buckets.get(key, (self.capacity, now))
            tokens = min(self.capacity, tokens + (now - stamp) * self.rate)
            return 0.0 if tokens >= 1.0 else (1.0 - tokens) / self.rate

    @staticmethod
    def retry_after(wait: float) -> int:
        """``Retry-After`` in whole seconds (at least 1) for a wait of ``wait`` [s]."""
        return max(1, math.ceil(wait))
