"""A job for the cancellation tests (API, console, Chromium): it reports progress every few
milliseconds until it is stopped."""

from __future__ import annotations

import threading
import time
from typing import Any

from app.services.jobs import JobFunction, Progress

__all__ = ["reports_until_cancelled"]


def reports_until_cancelled(started: threading.Event, seconds: float = 60.0) -> JobFunction:
    """A job that reports a slowly growing fraction (below 0.9) every 5 ms, sets
    ``started`` at its first report and, if nothing stops it, returns after ``seconds``
    [s] with the number of its reports."""
    def run(params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        deadline = time.monotonic() + seconds
        step = 0
        while time.monotonic() < deadline:
            step += 1
            progress(min(0.9, step / 1000), f"step {step}")
            started.set()
            time.sleep(0.005)
        return {"steps": step}
    return run
