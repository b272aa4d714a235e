"""Targets judged with their Monte-Carlo error (benchmarks/targets.py) and the two studies'
target lists (benchmarks/accuracy_figures.issue_targets, benchmarks/discrepancy_targets)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy.stats import binom

from benchmarks import targets
from benchmarks.accuracy_figures import issue_targets as accuracy_targets
from benchmarks.discrepancy_targets import issue_targets as discrepancy_targets


@pytest.mark.parametrize(("k", "n", "low", "high"), [
    # hand calculation of (p + z²/2n ± z·√(p(1−p)/n + z²/4n²)) / (1 + z²/n), z = 1.95996
    (0, 10, 0.0, 0.27753),
    (5, 10, 0.23659, 0.76341),
    (10, 10, 0.72247, 1.0),
    (126, 150, 0.77296, 0.89006),
    (0, 24, 0.0, 0.13797),
])
def test_wilson_interval_matches_the_hand_calculation(k: int, n: int, low: float,
                                                       high: float) -> None:
    lo, hi = targets.wilson(k, n)
    assert lo == pytest.approx(low, abs=2e-5)
    assert hi == pytest.approx(high, abs=2e-5)


def test_wilson_interval_is_symmetric_and_holds_the_share() -> None:
    for n in (1, 7, 40, 801):
        for k in range(0, n + 1, max(1, n // 9)):
            lo, hi = targets.wilson(k, n)
            lo2, hi2 = targets.wilson(n - k, n)
            assert lo == pytest.approx(1 - hi2, abs=1e-12)
            assert hi == pytest.approx(1 - lo2, abs=1e-12)
            assert lo <= k / n <= hi


def test_wilson_interval_covers_about_95_percent_of_draws() -> None:
    """Over 20,000 binomial draws (p = 0.9, n = 50 and p = 0.03, n = 300) the interval
    holds the true p in 93-97.5 % of them (Brown, Cai & DasGupta 2001: Wilson's coverage
    stays near the nominal level where the normal interval's does not)."""
    rng = np.random.default_rng(11)
    for p, n in ((0.9, 50), (0.03, 300)):
        ks = rng.binomial(n, p, 20_000)
        cover = np.mean([lo <= p <= hi for lo, hi in (targets.wilson(int(k), n) for k in ks)])
        assert 0.93 <= cover <= 0.975, (p, n, cover)


def test_wilson_refuses_a_count_outside_its_cases() -> None:
    with pytest.raises(ValueError, match=r"lie in 0\.\.n"):
        targets.wilson(11, 10)
    assert all(math.isnan(x) for x in targets.wilson(0, 0))


def test_median_interval_is_the_order_statistics_of_at_least_95_percent() -> None:
    x = np.arange(1.0, 11.0)  # n = 10: [x₂, x₉], coverage 1 − 2·P(Bin(10, ½) ≤ 1) = 97.9 %
    t = targets.median("m", list(x[::-1]), 5.0, at_least=True)
    assert (t.value, t.low, t.high) == (5.5, 2.0, 9.0)
    for n in (6, 9, 30, 101):
        t = targets.median("m", list(np.arange(n, dtype=float)), 0.0, at_least=True)
        j = int(t.low) + 1  # the j-th smallest is the low end
        assert t.high == n - j  # the j-th largest the high end
        assert 2 * binom.cdf(j - 1, n, 0.5) <= 0.05  # the interval's coverage ≥ 95 %
        assert 2 * binom.cdf(j, n, 0.5) > 0.05  # and the narrowest such
    few = targets.median("m", [1.0, 2.0, 3.0, 4.0, 5.0], 2.0, at_least=True)
    assert (few.low, few.high, few.verdict) == (-math.inf, math.inf, "not decided")


@pytest.mark.parametrize(("k", "n", "goal", "at_least", "verdict"), [
    (148, 150, 0.95, True, "met"),  # [0.953, 0.996]
    (126, 150, 0.95, True, "missed"),  # [0.773, 0.889]
    (20, 20, 0.95, True, "not decided"),  # [0.839, 1]
    (0, 1002, 0.01, False, "met"),  # [0, 0.0038]
    (0, 24, 0.05, False, "not decided"),  # [0, 0.138]
    (10, 100, 0.02, False, "missed"),  # [0.055, 0.174]
])
def test_a_share_is_met_missed_or_not_decided_by_its_interval(
        k: int, n: int, goal: float, at_least: bool, verdict: str) -> None:
    assert targets.share("s", k, n, goal, at_least=at_least).verdict == verdict


def test_a_clustered_share_widens_where_a_cluster_misses_together() -> None:
    """Nine seeds with all 5 parameters inside and one with none: p = 0.9, SE² =
    10/9 · (9 · 0.5² + 4.5²) / 50² = 0.1², so 0.9 ± 0.196 — wider than Wilson's
    [0.786, 0.957] for 45 of 50 independent cases."""
    together = targets.clustered_share("c", [(5, 5)] * 9 + [(0, 5)], 0.93, at_least=True)
    assert together.value == 0.9
    assert together.low == pytest.approx(0.9 - targets.Z95 * 0.1, abs=1e-12)
    assert together.high == 1.0
    # misses spread one a seed: the clusters vary less than independent cases would
    # (SE 1/30 against √(0.9·0.1/50) = 0.042), Wilson's lower end stays
    spread = targets.clustered_share("c", [(4, 5)] * 5 + [(5, 5)] * 5, 0.93, at_least=True)
    assert spread.low == targets.wilson(45, 50)[0]
    assert spread.high == pytest.approx(0.9 + targets.Z95 / 30, abs=1e-12)
    assert targets.clustered_share("c", [], 0.5, at_least=True).verdict == "no cases"


def test_a_mean_and_a_count() -> None:
    brier = [0.0] * 90 + [1.0] * 10  # 0.1 ± 1.96·0.0302: [0.041, 0.159]
    t = targets.mean("Brier", brier, 0.05, at_least=False)
    assert t.value == pytest.approx(0.1)
    assert t.low == pytest.approx(0.1 - targets.Z95 * 0.3 / math.sqrt(99), rel=1e-9)
    assert t.verdict == "not decided"
    assert targets.mean("Brier", [0.0] * 80 + [1.0] * 20, 0.05, at_least=False).verdict \
        == "missed"  # 0.2 ± 0.079
    assert targets.mean("Brier", [0.01] * 50, 0.05, at_least=False).verdict == "met"
    assert targets.count("5xx", 0, 420).verdict == "met"
    assert targets.count("5xx", 1, 420).verdict == "missed"
    assert targets.share("s", 0, 0, 0.5, at_least=True).verdict == "no cases"
    d = targets.share("s", 3, 4, 0.5, at_least=True).to_dict()
    assert d["verdict"] == "not decided" and d["n"] == 4 and d["sense"] == "at least"


def _row(suite: str, **score: Any) -> dict[str, Any]:
    base = {"suite": suite, "in_library": suite in ("preset", "differential"), "error": None,
            "top1_grouped": 1.0, "in_set": 1.0, "brier_grouped": 0.0, "explained": 1.0,
            "flagged": 0.0}
    return base | score


def test_accuracy_targets_count_the_cases_of_each_target() -> None:
    full = ([_row("preset")] * 95 + [_row("preset", top1_grouped=0.0, brier_grouped=2.0)] * 5
            + [_row("misspecified", flagged=1.0)] * 30 + [_row("misspecified")] * 2
            + [_row("beyond_range", flagged=1.0)] * 10
            + [_row("preset", error="server: 500")])
    nfm = [_row("differential", explained=0.0)] * 4 + [_row("differential")] * 96
    comm = {"per_seed": [[5, 5]] * 7 + [[4, 5]] * 3,
            "per_parameter": {"cylinder.Fu": {"pinned_in_seeds": 9, "coverage": 7 / 9}}}
    got = {t.name: t for t in accuracy_targets({"full": full, "no_flow_meters": nfm}, comm)}
    assert got["server errors (every suite and sensor set)"].value == 1.0
    assert got["server errors (every suite and sensor set)"].verdict == "missed"
    top1 = got["top-1* in library, full sensors"]
    assert (top1.n, top1.value) == (100, 0.95)
    assert got["Brier* in library, full sensors"].value == pytest.approx(0.1)
    assert got["not explained in library, no_flow_meters"].value == pytest.approx(0.04)
    mis = got["misfit detected, misspecified, full"]
    assert (mis.n, mis.value) == (32, 30 / 32)
    assert got["misfit detected, beyond_range, full"].n == 10
    assert got["misfit detected, beyond_range, no_flow_meters"].verdict == "no cases"
    comm_t = got["commissioning coverage, (seed, parameter) pairs"]
    assert (comm_t.n, comm_t.value) == (50, 47 / 50)
    fu = got["commissioning coverage, cylinder.Fu (seeds that pin it)"]
    assert (fu.n, fu.value) == (9, 7 / 9)


def test_discrepancy_targets_pool_the_sizes_and_read_the_steady_rows() -> None:
    hidden = ([{"size": 8.0, "outcome": "exact", "rmse_ratio": 90.0}] * 28
              + [{"size": 8.0, "outcome": "none"}] * 4
              + [{"size": 16.0, "outcome": "exact", "rmse_ratio": math.nan}] * 28
              + [{"size": 16.0, "outcome": "wrong"}] * 4
              + [{"size": 4.0, "outcome": "exact", "rmse_ratio": 3.0}] * 28
              + [{"size": 4.0, "outcome": "failed"}] * 4)
    summary = {"sizes_sigma": [4.0, 8.0, 16.0], "no_effect_cases": 24, "false_discoveries": 0,
               "steady_no_effect_cases": 1002, "steady_false_discoveries": 0,
               "out_of_library_cases": 50, "out_of_library_flagged": 50,
               "steady_rows": [{"size_sigma": 8.0, "n": 10, "exact": 0.9, "wrong": 0.1},
                               {"size_sigma": 4.0, "n": 10, "exact": 0.7, "wrong": 0.0}]}
    got = {t.name: t for t in discrepancy_targets(summary, hidden)}
    strong = got["exact name, transient cases, 8 and 16 σ"]
    assert (strong.n, strong.value, strong.verdict) == (64, 56 / 64, "missed")
    assert got["exact name, transient cases, 4 σ"].value == 28 / 32
    assert got["wrong name, transient cases, 8 and 16 σ"].value == 4 / 64
    assert got["exact name, steady tables, 8 and 16 σ"].value == 0.9
    assert got["wrong name, steady tables, 8 and 16 σ"].value == 0.1
    assert got["exact name, steady tables, 4 σ"].n == 10
    assert got["false discoveries, dynamic no-effect cases"].verdict == "not decided"
    assert got["false discoveries, steady no-effect tables"].verdict == "met"
    rmse = got["held-out RMSE reduction when named (median)"]
    assert (rmse.n, rmse.value, rmse.verdict) == (56, 46.5, "not decided")  # NaN left out
    assert got["out of library not confidently named"].verdict == "met"
