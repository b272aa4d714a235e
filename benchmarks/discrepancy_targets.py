"""Issue 8's targets of the hidden-effect bench, each with its 95 % interval over the
study's random cases and a verdict (:mod:`benchmarks.targets`).

* exact name ≥ 95 % of the hidden-effect cases whose effect peaks at ≥ 8 σ, ≥ 75 % at 4 σ;
  a wrong name ≤ 3 % at ≥ 8 σ — for the transient cases (cylinder, valve and pump on the
  rig's cycle) and the steady pump-bench tables apart, as the study prints them;
* false discoveries ≤ 5 % of the dynamic no-effect cases and ≤ 1 % of the steady tables;
* median held-out RMSE reduction ≥ 5× over the cases where an effect was named;
* out-of-library cases not confidently named (unexplained, or partly) ≥ 80 %.

A case whose simulation failed counts against the exact name (it named nothing).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from benchmarks import targets

__all__ = ["issue_targets"]


def _at(sizes: Sequence[float], low: float, high: float) -> str:
    chosen = [s for s in sizes if low <= s < high]
    return " and ".join(f"{s:g}" for s in chosen) + " σ"


def _names(kind: str, cases: list[tuple[float, str]], sizes: Sequence[float]
           ) -> list[targets.Target]:
    """Exact and wrong names of ``cases`` (size σ, outcome) against the issue's goals."""
    out = []
    for low, high, goal in ((8.0, float("inf"), 0.95), (4.0, 8.0, 0.75)):
        sel = [o for s, o in cases if low <= s < high]
        if sel:
            out.append(targets.share(f"exact name, {kind}, {_at(sizes, low, high)}",
                                     sum(o == "exact" for o in sel), len(sel), goal,
                                     at_least=True))
    strong = [o for s, o in cases if s >= 8.0]
    if strong:
        out.append(targets.share(f"wrong name, {kind}, {_at(sizes, 8.0, float('inf'))}",
                                 sum(o == "wrong" for o in strong), len(strong), 0.03,
                                 at_least=False))
    return out


def issue_targets(summary: dict[str, Any], hidden: list[dict[str, Any]]
                  ) -> list[targets.Target]:
    """The targets from the study's ``summary`` (its JSON object) and its ``hidden`` cases
    (one dict per case: ``size`` [σ], ``outcome``, ``rmse_ratio`` where named)."""
    sizes = [float(s) for s in summary.get("sizes_sigma", [])]
    out = _names("transient cases", [(float(r["size"]), r["outcome"]) for r in hidden], sizes)
    steady: list[tuple[float, str]] = []
    for row in summary.get("steady_rows", []):  # rates over n tables per (effect, size)
        n, size = int(row["n"]), float(row["size_sigma"])
        exact, wrong = round(row["exact"] * n), round(row["wrong"] * n)
        steady += [(size, "exact")] * exact + [(size, "wrong")] * wrong \
            + [(size, "other")] * (n - exact - wrong)
    out += _names("steady tables", steady, sizes)
    if summary.get("no_effect_cases"):
        out.append(targets.share("false discoveries, dynamic no-effect cases",
                                 summary["false_discoveries"], summary["no_effect_cases"],
                                 0.05, at_least=False))
    if summary.get("steady_no_effect_cases"):
        out.append(targets.share("false discoveries, steady no-effect tables",
                                 summary["steady_false_discoveries"],
                                 summary["steady_no_effect_cases"], 0.01, at_least=False))
    ratios = [r["rmse_ratio"] for r in hidden if math.isfinite(r.get("rmse_ratio", math.nan))]
    if ratios:
        out.append(targets.median("held-out RMSE reduction when named (median)", ratios,
                                  5.0, at_least=True))
    if summary.get("out_of_library_cases"):
        out.append(targets.share("out of library not confidently named",
                                 summary["out_of_library_flagged"],
                                 summary["out_of_library_cases"], 0.80, at_least=True))
    return out
