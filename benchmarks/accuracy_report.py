"""Breakdowns of the accuracy study (:mod:`benchmarks.accuracy`): where the misses go.

* :func:`confusions` — which truths are lost to which answers (grouped top-1 misses, an
  unexplained answer counted as ``"unexplained"``);
* :func:`hypothesis_calibration` — calibration in the large per hypothesis: the sum of the
  probabilities the diagnosis stated for a hypothesis over all cases against the number of
  cases in which it was the truth (equal when the stated probabilities are calibrated);
* :func:`miss_reasons` — each grouped top-1 miss of an in-library case classified by
  why it was missed: ``stalled`` (a stroke stalled or crept in the transient cycle and
  no hypothesis passed the χ² test, the end-stop state of the steady model included:
  a model limit); ``unexplained`` (the piston moved but no hypothesis passed the χ²
  test);
  ``not_separable`` (physics: the truth passes the χ² test, it is in the stated
  ambiguity set, and another hypothesis was more probable — these readings cannot
  reject either); ``rejected`` (the truth failed the χ² test while another passed:
  a model mismatch between the transient and the steady model, or an evidence error);
* :func:`moving_figures` — the in-library figures without the cases whose piston stalled
  or crept (fitted with the end-stop state of the steady model; shown apart so that the
  moving cases' figures compare with earlier studies).
"""

from __future__ import annotations

from collections import Counter, defaultdict
from typing import Any

import numpy as np

__all__ = ["confusions", "hypothesis_calibration", "miss_reasons", "moving_figures"]

#: the reasons of :func:`miss_reasons`, in the order they are tested
REASONS = ("stalled", "unexplained", "not_separable", "rejected")


def miss_reason(row: dict[str, Any]) -> str:
    """Why an in-library case was missed (one of :data:`REASONS`; module docstring)."""
    if not row["explained"]:
        return "stalled" if row["stalled"] else "unexplained"
    return "not_separable" if row["in_set"] else "rejected"


def miss_reasons(rows: list[dict[str, Any]]) -> dict[str, int]:
    """Counts of the grouped top-1 misses by :func:`miss_reason` (every reason listed)."""
    c = Counter(miss_reason(r) for r in rows if r["error"] is None and not r["top1_grouped"])
    return {k: c[k] for k in REASONS}


def confusions(rows: list[dict[str, Any]], top: int = 6) -> list[tuple[str, str, int]]:
    """The ``top`` most frequent (truth, answer, count) among grouped top-1 misses."""
    c: Counter[tuple[str, str]] = Counter(
        (r["truth"], r["top"]) for r in rows if r["error"] is None and not r["top1_grouped"])
    return [(t, a, n) for (t, a), n in c.most_common(top)]


def hypothesis_calibration(rows: list[dict[str, Any]]) -> dict[str, list[float]]:
    """Per hypothesis: [sum of stated probabilities, cases where it was the truth]."""
    stated: dict[str, float] = defaultdict(float)
    truths: Counter[str] = Counter()
    for r in rows:
        if r["error"] is not None:
            continue
        for h, p in r["probs"].items():
            stated[h] += p
        truths[r["truth"]] += 1
    return {h: [round(stated[h], 1), truths[h]] for h in sorted(set(stated) | set(truths))}


def moving_figures(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Grouped top-1, Brier and share not explained over the cases that did not stall."""
    ok = [r for r in rows if r["error"] is None and not r["stalled"]]
    if not ok:
        return {}
    return {"n": len(ok),
            "top1_grouped": float(np.mean([r["top1_grouped"] for r in ok])),
            "brier_grouped": float(np.mean([r["brier_grouped"] for r in ok])),
            "not_explained": 1.0 - float(np.mean([r["explained"] for r in ok]))}
