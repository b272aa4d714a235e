"""Each candidate's variance inflation factor: computed beside the base columns, reported in
the selection, the JSON and HTML reports and the CLI, never filtered on (DISCREPANCY.md,
"Pitfalls")."""

from __future__ import annotations

import math

import numpy as np
import pytest
from statsmodels.stats.outliers_influence import variance_inflation_factor

from diagnostics.discrepancy.balances import BALANCES, BalanceData
from diagnostics.discrepancy.report import html_page
from diagnostics.discrepancy.selection import select
from diagnostics.discrepancy.steady import discover_steady
from diagnostics.discrepancy.synthetic import synthesize_bench
from diagnostics.discrepancy.vif import candidate_vif, vif
from sim.rigs import reference_rig, reference_rig_document


def _correlated(r: float, n: int = 200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two orthonormal columns of mean zero, ``a`` and ``c``, and ``b = r·a + √(1 − r²)·c``:
    corr(a, b) = r exactly."""
    rng = np.random.default_rng(3)
    m = rng.normal(size=(n, 2))
    q, _ = np.linalg.qr(m - m.mean(axis=0))
    a, c = q[:, 0], q[:, 1]
    return a, c, r * a + math.sqrt(1.0 - r * r) * c


@pytest.mark.parametrize("r", [0.0, 0.5, 0.9, 0.987, -0.99])
def test_two_columns_of_correlation_r_give_one_over_one_minus_r_squared(r: float) -> None:
    a, _, b = _correlated(r)
    # on any scale: the selection's unit-RMS columns and SI columns give the same number
    assert vif(a[:, None], b) == pytest.approx(1.0 / (1.0 - r * r), rel=1e-9)
    got = candidate_vif({"pump.Rlp": 1e-5 * a}, {"turbulent_pump_slip": 3e7 * b})
    assert got["turbulent_pump_slip"] == pytest.approx(1.0 / (1.0 - r * r), rel=1e-9)
    # the design notes' example: √Δp beside Δp at r = 0.987 reads ≈ 39 (≫ 10, kept)
    if r == 0.987:
        assert got["turbulent_pump_slip"] == pytest.approx(38.7, abs=0.1)


def test_the_vif_is_statsmodels_uncentred_one_on_a_design_without_a_constant() -> None:
    rng = np.random.default_rng(4)
    x = rng.uniform(0.5, 2.0, size=(60, 2))
    base = {"p": x[:, 0], "w": x[:, 1]}
    cand = {"sq": np.sqrt(x[:, 0]) * x[:, 1], "w2": x[:, 1] ** 2}
    got = candidate_vif(base, cand)
    for j, name in enumerate(cand):
        exog = np.column_stack([x, cand[name]])
        try:   # statsmodels ≥ 0.15 centres the columns unless told not to
            expected = variance_inflation_factor(exog, 2, standardize=False)
        except TypeError:   # 0.14: the columns as given (no constant: the uncentred R²)
            expected = variance_inflation_factor(exog, 2)
        assert got[name] == pytest.approx(expected, rel=1e-8), j


def test_a_column_in_the_base_span_or_of_zeros_is_infinite() -> None:
    a, c, _ = _correlated(0.3)
    got = candidate_vif({"x": a, "y": c}, {"in_span": 2 * a - c, "zeros": 0 * a, "free": a * c})
    assert math.isinf(got["in_span"]) and math.isinf(got["zeros"])
    assert 1.0 <= got["free"] < 2.0
    assert vif(np.zeros((a.size, 0)), a) == 1.0


def test_the_selection_carries_the_vif_and_does_not_filter_on_it() -> None:
    # a true effect whose column repeats the base column at r = 0.99 (VIF ≈ 50): named
    r = 0.99
    a, _, b = _correlated(r)
    rng = np.random.default_rng(5)
    pump = next(x for x in BALANCES if x.name == "pump_flow")
    y = 2e-6 * a + 1e-6 * b + 1e-9 * rng.normal(size=a.size)   # [m³/s]
    data = BalanceData(pump, y, {"pump.Rlp": a}, {"turbulent_pump_slip": b},
                       np.ones(a.size, dtype=bool), 1e-5, {})
    sel = select(data, bootstrap=0, lags=0, block=1)
    assert sel.vif["turbulent_pump_slip"] == pytest.approx(1.0 / (1.0 - r * r), rel=1e-9)
    assert sel.chosen is not None
    assert [t.effect for t in sel.chosen.terms] == ["turbulent_pump_slip"]
    assert sel.candidate_dicts()["turbulent_pump_slip"]["vif"] == pytest.approx(50.25, rel=1e-3)


def test_the_reports_carry_each_candidates_vif() -> None:
    bench = synthesize_bench(reference_rig(), rng=np.random.default_rng(8),
                             effects={"speed_offset": 1.0})
    d = discover_steady(reference_rig_document(), bench, bootstrap=0)
    sel = d.selections[0]
    data = d.traces["data"][0]
    expected = candidate_vif(data.base, data.candidates)
    assert set(expected) == set(data.candidates) and sel.vif == expected
    balance = d.to_dict()["balances"][0]
    assert balance["vif"] == pytest.approx(expected)
    for name, c in balance["candidates"].items():
        assert c["vif"] == pytest.approx(expected[name])
    # √Δp beside Δp and ω over 5-50 bar: the most inflated column of the bench design
    assert max(expected, key=lambda k: expected[k]) == "turbulent_pump_slip"
    assert expected["turbulent_pump_slip"] > 10.0   # and it stays a candidate
    page = html_page(d)
    assert "VIF per candidate" in page
    assert f"turbulent_pump_slip: {expected['turbulent_pump_slip']:.4g}" in page


def test_the_cli_lists_the_candidates_with_their_vif() -> None:
    from rich.console import Console

    from app.cli_discover import candidate_table

    bench = synthesize_bench(reference_rig(), rng=np.random.default_rng(8),
                             effects={"speed_offset": 1.0})
    d = discover_steady(reference_rig_document(), bench, bootstrap=0)
    console = Console(width=200, record=True)
    console.print(candidate_table(d.selections))
    text = console.export_text()
    assert "VIF" in text and "minimum detectable RMS" in text
    row = next(line for line in text.splitlines() if "turbulent_pump_slip" in line)
    assert f"{d.selections[0].vif['turbulent_pump_slip']:.3g}" in row and "l/min" in row
    chosen = next(line for line in text.splitlines() if "speed_offset" in line)
    assert "yes" in chosen
