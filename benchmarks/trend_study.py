"""Trend study: does the time left hold the true crossing, and is a step found (and only a
step)?

Run: ``python -m benchmarks.trend_study`` (``make trend-study``); ``HYDRODIAG_LIGHT=1``
runs fewer campaigns (CI).  Three parts, each on simulated histories with Gaussian scatter
(a seal wearing 83 → 130 µm over 266 days, its threshold 132.84 µm, readings ±2 µm, visits
at uniform random times):

* **coverage** of the 95 % time-left interval of
  :func:`diagnostics.trends.forecast_threshold` against the true crossing, at 10-400
  visits, and of the interval the lines through the median-value pivot gave before stop 45
  (computed here from the same slope interval), with one reading's date wrong in a last row;
* **null** distribution of :func:`diagnostics.level_shift.level_shift`'s sup-F on straight
  lines (the source of :data:`diagnostics.level_shift.CRITICAL_F`): its 99th percentile by
  number of visits;
* **steps**: how often a step is reported on straight, flat and wrong-dated histories
  (false), and on 12 µm and 6 µm steps with and without wear after them and on
  accelerating wear (found, and where, as a fraction of the span);
* **cost** of the step search: one forecast of a 400-35,000-visit history with and without
  it (best of 5, as a ratio).

The last line is one JSON object with the figures.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable

import numpy as np

import diagnostics.level_shift as shift_module
from diagnostics.level_shift import level_shift
from diagnostics.trends import TrendSeries, forecast_threshold, theil_sen

DAY = 86400.0
SPAN = 266 * DAY
C0, RATE, THRESHOLD, SIGMA = 83e-6, 0.1767e-6 / DAY, 132.84e-6, 2e-6


def _wear(rng: np.random.Generator, n: int, wrong_date: bool = False
          ) -> tuple[np.ndarray, np.ndarray]:
    t = np.sort(rng.uniform(0, SPAN, n))
    y = C0 + RATE * t + rng.normal(0, SIGMA, n)
    if wrong_date:   # a late reading typed with a date early in the campaign
        t[-2] = 0.2 * SPAN
    return t, y


def coverage(rng: np.random.Generator, n: int, trials: int, wrong_date: bool = False
             ) -> dict[str, float]:
    """Share of campaigns whose 95 % time-left interval holds the truth, and the median
    width [days]: the forecast's and the median-value pivot's."""
    held = {"forecast": 0, "pivot": 0}
    widths: dict[str, list[float]] = {"forecast": [], "pivot": []}
    for _ in range(trials):
        t, y = _wear(rng, n, wrong_date)
        now = float(t.max())
        truth = (THRESHOLD - C0) / RATE - now
        fc = forecast_threshold(TrendSeries("r", "cylinder", "cc", "m", tuple(t), tuple(y),
                                            (SIGMA,) * n), THRESHOLD, steps=False)
        assert fc.fit is not None
        lo, hi = fc.fit.slope_low, fc.fit.slope_high
        tp, yp = float(np.median(t)), float(np.median(y))
        pivot = (tp + (THRESHOLD - yp) / hi - now,
                 tp + (THRESHOLD - yp) / lo - now if lo > 0 else math.inf)
        for key, (a, b) in (("forecast", (fc.time_left_low, fc.time_left_high)),
                            ("pivot", pivot)):
            held[key] += a <= truth <= b
            widths[key].append((b - a) / DAY)
    return {f"{k}_held": held[k] / trials for k in held} | \
        {f"{k}_width_days": float(np.median(widths[k])) for k in widths}


def null_quantile(rng: np.random.Generator, n: int, trials: int) -> float:
    """99th percentile of the sup-F of straight lines (no critical value, no floor)."""
    critical, practical = shift_module.critical_f, shift_module.PRACTICAL
    shift_module.critical_f = lambda _n: 0.0       # type: ignore[assignment]
    shift_module.PRACTICAL = 0.0
    try:
        stats = []
        for _ in range(trials):
            t, y = _wear(rng, n)
            found = level_shift(t, y, theil_sen(t, y)[0])
            stats.append(found.f_stat if found is not None else 0.0)
    finally:
        shift_module.critical_f = critical           # type: ignore[assignment]
        shift_module.PRACTICAL = practical
    return float(np.quantile(stats, 0.99))


CASES: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "straight": lambda t: C0 + RATE * t,
    "flat": lambda t: np.full(t.size, 34e-6),
    "step 12 µm": lambda t: np.where(t >= 0.5 * SPAN, 46e-6, 34e-6),
    "step 6 µm": lambda t: np.where(t >= 0.5 * SPAN, 40e-6, 34e-6),
    "step 6 µm + wear": lambda t: np.where(t >= 0.5 * SPAN, 40e-6, 34e-6) + 0.05e-6 / DAY * t,
    "accelerating": lambda t: C0 + 40e-6 * (t / SPAN) ** 2,
}


def steps(rng: np.random.Generator, kind: str, n: int, trials: int) -> dict[str, float]:
    """Share of histories with a step reported, and the median place of it [span]; −1
    when none is."""
    hits, where = 0, []
    for _ in range(trials):
        if kind == "wrong date":
            t, y = _wear(rng, n, wrong_date=True)
        else:
            t = np.sort(rng.uniform(0, SPAN, n))
            y = CASES[kind](t) + rng.normal(0, SIGMA, n)
        found = level_shift(t, y, theil_sen(t, y)[0], SIGMA)
        if found is not None:
            hits += 1
            where.append(found.time / SPAN)
    return {"reported": hits / trials, "at": float(np.median(where)) if where else -1.0}


def main() -> None:
    light = os.environ.get("HYDRODIAG_LIGHT") == "1"
    started = time.perf_counter()
    rng = np.random.default_rng(45)
    scale = 0.25 if light else 1.0
    out: dict[str, object] = {"light": light}
    print("time left: share of campaigns whose 95 % interval holds the true crossing")
    print(f"{'visits':>8s} {'forecast':>9s} {'pivot':>7s} {'width [d]':>10s}")
    cov = {}
    for n, wrong in ((10, False), (40, False), (100, False), (400, False), (40, True)):
        trials = max(int((400 if n < 400 else 150) * scale), 40)
        c = coverage(rng, n, trials, wrong)
        key = f"{n}{' wrong date' if wrong else ''}"
        cov[key] = {k: round(v, 3) for k, v in c.items()} | {"campaigns": trials}
        print(f"{key:>8s} {c['forecast_held']:9.3f} {c['pivot_held']:7.3f} "
              f"{c['forecast_width_days']:10.1f}")
    out["coverage"] = cov
    print("\nlevel shift: 99th percentile of sup-F on straight lines, against the critical value")
    null = {}
    for n in (10, 25, 100, 400):
        trials = max(int((2000 if n <= 100 else 600) * scale), 200)
        q = null_quantile(rng, n, trials)
        null[str(n)] = {"q99": round(q, 2), "critical": round(shift_module.critical_f(n), 2),
                        "lines": trials}
        print(f"{n:>8d} {q:7.2f} {shift_module.critical_f(n):7.2f}")
    out["null"] = null
    print("\nlevel shift reported (share; median place as a fraction of the span)")
    sizes = (10, 20, 40, 100, 400)
    print(f"{'history':>18s} " + " ".join(f"{'n=' + str(n):>12s}" for n in sizes))
    found: dict[str, dict[str, object]] = {}
    for kind in ("straight", "flat", "wrong date", *list(CASES)[2:]):
        row = {}
        cells = []
        for n in sizes:
            trials = max(int((300 if n <= 100 else 100) * scale), 30)
            r = steps(rng, kind, n, trials)
            row[str(n)] = {k: round(v, 3) for k, v in r.items()} | {"histories": trials}
            cells.append(f"{r['reported']:5.2f}" + (f" @{r['at']:.2f}" if r["reported"] else
                                                    "      "))
        found[kind] = row
        print(f"{kind:>18s} " + " ".join(f"{c:>12s}" for c in cells))
    out["steps"] = found
    print("\nforecast of one long history, best of 5 [ms]: without and with the step search")
    cost = {}
    for n in (400, 12_600, 35_000):
        t, y = _wear(rng, n)
        series = TrendSeries("r", "cylinder", "cc", "m", tuple(t), tuple(y), (SIGMA,) * n)
        best = []
        for with_steps in (False, True):
            runs = []
            for _ in range(5):
                t0 = time.perf_counter()
                forecast_threshold(series, THRESHOLD, steps=with_steps)
                runs.append(time.perf_counter() - t0)
            best.append(1e3 * min(runs))
        cost[str(n)] = {"plain_ms": round(best[0], 2), "steps_ms": round(best[1], 2),
                        "ratio": round(best[1] / best[0], 3)}
        print(f"{n:>8d} {best[0]:8.1f} {best[1]:8.1f}  × {best[1] / best[0]:.2f}")
    out["step_search_cost"] = cost
    out["wall_s"] = round(time.perf_counter() - started, 1)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
