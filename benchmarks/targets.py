"""A study's targets judged with their Monte-Carlo error: met, missed, or not decided.

A study's rate is a count over a finite number of random cases: 0 false discoveries in 24
no-effect cases is a rate of 0 whose 95 % interval reaches 14 %, so it cannot say that a
≤ 5 % target is met; 126 of 150 mis-specified cases flagged (0.84) is below a 95 % target
beyond any doubt of the draw.  Each target here carries its figure, the 95 % interval of
that figure over the study's random draws, and a verdict read from the interval:

* ``met`` — the whole interval is on the target's side;
* ``missed`` — the whole interval is on the wrong side;
* ``not decided`` — the interval straddles the target: more cases would tell (the
  figure alone would have said met or missed by the luck of the draw).

Intervals:

* a share of cases (:func:`share`) — Wilson's score interval of a binomial proportion
  (Wilson, *J. Am. Stat. Assoc.* 22, 1927; Brown, Cai & DasGupta, *Statistical Science* 16,
  2001, recommend it over the normal ("Wald") interval, of zero width at 0 of n);
* a share of cases drawn in clusters that share a draw (:func:`clustered_share`: the
  parameters of one commissioning seed) — the wider of Wilson's interval and the ratio
  estimator's cluster-robust one, p̂ ± 1.96·SE with SE² = m/(m − 1)·Σ(kₛ − p̂·nₛ)²/(Σnₛ)²
  over the m clusters (Cochran, *Sampling Techniques*, 1977, §6.4); pairs of one seed that
  miss together count as fewer independent cases;
* a mean of per-case scores such as the Brier score (:func:`mean`) — mean ± 1.96 standard
  errors (the central limit theorem; the scores are bounded);
* a median such as the held-out RMSE reduction (:func:`median`) — the distribution-free
  order-statistic interval [x₍ⱼ₎, x₍ₙ₋ⱼ₊₁₎], j the largest with P(Bin(n, ½) < j) ≤ 2.5 %;
* a count that must be zero, such as server errors (:func:`count`) — no interval: one is
  a defect, whatever the draw.

The other intervals take the cases as independent draws.  :func:`table` prints them;
:func:`as_json` gives the list for a study's last JSON line.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import binom
from statsmodels.stats.proportion import proportion_confint

__all__ = ["Z95", "Target", "as_json", "clustered_share", "count", "mean", "median", "share",
           "table", "wilson"]

#: the standard normal's 97.5 % quantile: two-sided 95 % intervals
Z95 = 1.959963984540054


def wilson(k: int, n: int) -> tuple[float, float]:
    """Wilson's score interval (95 %) of a proportion ``k``/``n`` [-] (statsmodels'
    ``proportion_confint``); (nan, nan) when n = 0."""
    if n <= 0:
        return math.nan, math.nan
    if not 0 <= k <= n:
        raise ValueError(f"{k} of {n}: a count of cases must lie in 0..n")
    low, high = proportion_confint(k, n, alpha=0.05, method="wilson")
    # at k = 0 or k = n one end is exactly 0 or 1 (its formula leaves 1e-19)
    return (0.0 if k == 0 else float(low)), (1.0 if k == n else float(high))


@dataclass(frozen=True)
class Target:
    """One target of a study: ``value`` [the figure's unit] against ``goal``, at least
    (``at_least``) or at most; ``low``/``high`` its 95 % interval (equal to ``value`` for
    a count); ``n`` the cases it is read from; ``kind`` how the interval was made."""

    name: str
    value: float
    low: float
    high: float
    goal: float
    at_least: bool
    n: int
    kind: str

    @property
    def verdict(self) -> str:
        """``met``, ``missed`` or ``not decided`` (see the module), ``no cases`` when none."""
        if self.n == 0 or math.isnan(self.value):
            return "no cases"
        good, bad = (self.low >= self.goal, self.high < self.goal) if self.at_least else \
            (self.high <= self.goal, self.low > self.goal)
        return "met" if good else "missed" if bad else "not decided"

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "value": _finite(self.value), "low": _finite(self.low),
                "high": _finite(self.high), "goal": self.goal,
                "sense": "at least" if self.at_least else "at most", "n": self.n,
                "interval": self.kind, "verdict": self.verdict}


def _finite(x: float) -> float | None:
    return None if math.isnan(x) else round(x, 6)


def share(name: str, k: int, n: int, goal: float, *, at_least: bool) -> Target:
    """A share of ``n`` cases, ``k`` of them counted, with Wilson's 95 % interval."""
    low, high = wilson(k, n)
    return Target(name, k / n if n else math.nan, low, high, goal, at_least, n, "Wilson 95 %")


def clustered_share(name: str, clusters: Sequence[tuple[int, int]], goal: float, *,
                    at_least: bool) -> Target:
    """A share of cases drawn in ``clusters`` of (counted, cases), the cases of a cluster
    sharing one draw: the wider of Wilson's and the cluster-robust interval (module)."""
    k = sum(c[0] for c in clusters)
    n = sum(c[1] for c in clusters)
    m = sum(1 for c in clusters if c[1] > 0)
    if n == 0:
        return Target(name, math.nan, math.nan, math.nan, goal, at_least, 0, "clustered")
    p = k / n
    low, high = wilson(k, n)
    if m > 1:
        se = math.sqrt(m / (m - 1) * sum((ks - p * ns) ** 2 for ks, ns in clusters)) / n
        low, high = min(low, max(0.0, p - Z95 * se)), max(high, min(1.0, p + Z95 * se))
    return Target(name, p, low, high, goal, at_least, n,
                  f"Wilson or cluster-robust 95 % ({m} clusters)")


def mean(name: str, scores: Sequence[float], goal: float, *, at_least: bool) -> Target:
    """The mean of per-case ``scores`` with its normal 95 % interval (mean ± 1.96 SE)."""
    x = np.asarray(scores, dtype=float)
    if x.size == 0:
        return Target(name, math.nan, math.nan, math.nan, goal, at_least, 0, "mean ± 1.96 SE")
    m = float(x.mean())
    se = float(x.std(ddof=1) / math.sqrt(x.size)) if x.size > 1 else math.inf
    return Target(name, m, m - Z95 * se, m + Z95 * se, goal, at_least, int(x.size),
                  "mean ± 1.96 SE")


def median(name: str, values: Sequence[float], goal: float, *, at_least: bool) -> Target:
    """The median of ``values`` with its order-statistic 95 % interval; with fewer than 6
    values no interval reaches 95 % and the interval is the whole range (±∞)."""
    x = np.sort(np.asarray(values, dtype=float))
    n = int(x.size)
    if n == 0:
        return Target(name, math.nan, math.nan, math.nan, goal, at_least, 0, "order statistics")
    j = int(binom.ppf(0.025, n, 0.5))  # P(Bin < j) < 2.5 %: the j-th value from each end
    low, high = (float(x[j - 1]), float(x[n - j])) if j >= 1 else (-math.inf, math.inf)
    return Target(name, float(np.median(x)), low, high, goal, at_least, n, "order statistics")


def count(name: str, k: int, n: int, goal: int = 0) -> Target:
    """A count of defects among ``n`` cases that must be at most ``goal``: no interval."""
    return Target(name, float(k), float(k), float(k), float(goal), False, n, "count")


def table(title: str, targets: Sequence[Target]) -> None:
    """Print ``targets`` as a table: figure, interval, target, verdict."""
    print(f"\n{title} (95 % interval over the study's random cases; 'not decided': the "
          "interval straddles the target)")
    print(f"{'target':58s} {'n':>5s} {'figure':>8s} {'95 % interval':>19s} {'goal':>9s}  "
          "verdict")
    for t in targets:
        sense = "≥" if t.at_least else "≤"
        interval = "—" if t.kind == "count" else f"[{t.low:.3g}, {t.high:.3g}]"
        print(f"{t.name:58s} {t.n:5d} {t.value:8.3g} {interval:>19s} {sense + f' {t.goal:g}':>9s}"
              f"  {t.verdict}")


def as_json(targets: Sequence[Target]) -> list[dict[str, object]]:
    """The targets for a study's JSON line."""
    return [t.to_dict() for t in targets]
