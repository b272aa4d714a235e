"""The timeline of a stored ``POST /diagnose`` from the service's ``/metrics``: where it
waits (``hydrodiag_diagnosis_stage_seconds``, :class:`app.metrics.HttpMetrics`)."""

from __future__ import annotations

import re

import httpx

__all__ = ["timeline"]

_STAGE = re.compile(r'^hydrodiag_diagnosis_stage_seconds_(sum|count)\{stage="(\w+)"\} (\S+)$')


def timeline(base_url: str) -> dict[str, float]:
    """Mean time of a stored ``POST /diagnose`` in each stage [ms], from one server
    process's ``/metrics`` (every request it has answered so far): ``request`` from its
    arrival to its answer, of which ``queue`` (for a diagnosis process), ``compute`` (in
    it), ``transfer`` (pipes and wake-ups), ``commit`` (group commit), and ``other`` the
    rest (parsing, validation, key check, routing)."""
    text = httpx.get(f"{base_url}/metrics", timeout=30).text
    sums: dict[str, float] = {}
    counts: dict[str, float] = {}
    for line in text.splitlines():
        if (m := _STAGE.match(line)) is not None:
            (sums if m.group(1) == "sum" else counts)[m.group(2)] = float(m.group(3))
    means = {k: 1e3 * sums[k] / counts[k] for k in sums if counts.get(k)}
    if "request" in means:
        means["other"] = means["request"] - sum(
            means.get(k, 0.0) for k in ("queue", "compute", "transfer", "commit"))
    return means
