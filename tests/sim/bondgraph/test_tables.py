"""Tabulated inputs: ``BondGraph.table``, the ``tbl:`` reference, ``table_lookup``, ``fit_table``."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.bondgraph import (
    BondGraph,
    C,
    MSe,
    One,
    R,
    call,
    compile_graph,
    derive_equations,
    fit_table,
    to_dict,
)
from sim.bondgraph.laws import linear_effort, linear_flow, quotient, table_lookup
from sim.errors import ModelStructureError, ParameterError

TAU = 0.4      # R·C of the lag [s]
SIZE = 8       # declared table size (the test series have 5 and 20 points)
#: input: 0 until t = 1 s, a jump to 1 at t = 1 s (repeated time), held to 3 s, a ramp down
#: to −0.5 at 5 s, then held
U_T = np.array([0.0, 1.0, 1.0, 3.0, 5.0])
U_V = np.array([0.0, 0.0, 1.0, 1.0, -0.5])


def lag_graph() -> BondGraph:
    """First-order lag driven by a table: MSe(u(t)) ─ 1 ─ R, C;  τ·dy/dt = u − y."""
    g = BondGraph("table_lag")
    g.parameter("R", TAU, "s", "test: τ = R·C with C = 1")
    g.parameter("C", 1.0, "1", "test")
    g.table("u", SIZE, unit="1", source="test input")
    g.add(MSe("U", table_lookup, "t", "tbl:u"))
    g.add(One("1"))
    g.add(R("R", flow=call(linear_flow, "e", "p:R"), effort=call(linear_effort, "f", "p:R")))
    g.add(C("C", quotient, "p:C", "1.0", scale=1.0))
    g.connect("U", "1")
    g.connect("1", "R")
    g.connect("1", "C")
    g.output("y", "effort:C", "1")
    return g


@pytest.fixture(scope="module")
def lag():
    return compile_graph(lag_graph())


def analytic_lag(t: np.ndarray, times: np.ndarray, values: np.ndarray, tau: float) -> np.ndarray:
    """Exact response of τ·y' = u − y, y(t_0) = u(t_0), to a piecewise-linear u (held ends).

    On a segment [a, b) where u = u_a + s·(t − a):
    y = u_a + s·(t − a) − s·τ + (y(a) − u_a + s·τ)·exp(−(t − a)/τ); y is continuous at jumps.
    """
    segs = [(times[i], times[i + 1], values[i], (values[i + 1] - values[i])
             / (times[i + 1] - times[i])) for i in range(times.size - 1)
            if times[i + 1] > times[i]]
    segs.append((times[-1], math.inf, values[-1], 0.0))

    def along(a: float, ua: float, s: float, ya: float, x: float) -> float:
        return ua + s * (x - a) - s * tau + (ya - ua + s * tau) * math.exp(-(x - a) / tau)

    starts = []
    y_a = values[0]
    for a, b, ua, s in segs:
        starts.append(y_a)
        if math.isfinite(b):
            y_a = along(a, ua, s, y_a, b)
    out = np.empty_like(t)
    for k, x in enumerate(t):
        i = max(0, max((j for j, sg in enumerate(segs) if sg[0] <= x), default=0))
        a, _, ua, s = segs[i]
        out[k] = along(a, ua, s, starts[i], x) if x >= a else values[0]
    return out


def test_lookup_interpolates_clamps_and_jumps():
    t, v = fit_table(U_T, U_V, SIZE)            # 5 points padded to 8 with the last one
    p = np.concatenate([np.zeros(3), t, v])     # the block after 3 named parameters
    x = np.linspace(-1.0, 7.0, 801)
    got = np.array([table_lookup(xi, p, 3, SIZE) for xi in x])
    off_jump = x != 1.0
    np.testing.assert_allclose(got[off_jump], np.interp(x, U_T, U_V)[off_jump], rtol=0,
                               atol=1e-15)
    # at the jump the law is right-continuous (np.interp would give the left value)
    assert table_lookup(1.0, p, 3, SIZE) == 1.0
    assert table_lookup(1.0 - 1e-12, p, 3, SIZE) == 0.0
    assert table_lookup(-5.0, p, 3, SIZE) == 0.0 and table_lookup(99.0, p, 3, SIZE) == -0.5


def test_first_order_system_driven_by_a_table_matches_the_analytic_response(lag):
    p = lag.params(tables={"u": (U_T, U_V)})
    res = lag.integrate(np.zeros(1), p, 8.0, rtol=1e-7, hmax=0.02)
    assert res.success
    y = lag.outputs(res.t, res.y, p)[:, 0]
    np.testing.assert_allclose(y, analytic_lag(res.t, U_T, U_V, TAU), rtol=0, atol=2e-5)
    # the response is a true lag: a quarter τ after the jump it is 1 − e^{−1/4}, not 1
    k = np.argmin(np.abs(res.t - (1.0 + TAU / 4)))
    assert y[k] == pytest.approx(1.0 - math.exp(-(res.t[k] - 1.0) / TAU), abs=2e-5)


def test_a_longer_series_is_resampled_and_the_response_follows_the_resampled_signal(lag):
    tt = np.linspace(0.0, 6.0, 25)
    vv = np.sin(tt)
    p = lag.params(tables={"u": (tt, vv)})
    off, n = lag.table_block("u")
    tu = np.linspace(0.0, 6.0, SIZE)
    np.testing.assert_allclose(p[off: off + n], tu)
    np.testing.assert_allclose(p[off + n: off + 2 * n], np.interp(tu, tt, vv), atol=1e-15)
    res = lag.integrate(np.zeros(1), p, 6.0, rtol=1e-7, hmax=0.02)
    y = lag.outputs(res.t, res.y, p)[:, 0]
    np.testing.assert_allclose(y, analytic_lag(res.t, tu, np.interp(tu, tt, vv), TAU),
                               atol=2e-5)


def test_defaults_overrides_and_layout(lag):
    p = lag.params({"R": 2.0})
    off, n = lag.table_block("u")
    assert off == len(lag.param_names) and p.size == off + 2 * n == len(lag.param_names) + 16
    assert p[lag.param_index("R")] == 2.0 and np.all(p[off + n:] == 0.0)
    # a constant table: the steady state is the constant
    q = lag.params(tables={"u": ([0.0], [0.7])})
    assert lag.steady(np.zeros(1), q)[0] == pytest.approx(0.7, abs=1e-12)
    assert to_dict(lag_graph())["tables"] == [{"name": "u", "size": SIZE, "unit": "1",
                                                "source": "test input"}]


def test_bad_tables_are_refused(lag):
    with pytest.raises(ParameterError):
        lag.params(tables={"nope": ([0.0], [1.0])})
    with pytest.raises(ParameterError):
        lag.params(tables={"u": ([0.0, 2.0, 1.0], [1.0, 2.0, 3.0])})
    with pytest.raises(ParameterError):
        lag.params(tables={"u": ([0.0, 1.0], [1.0, math.nan])})
    g = BondGraph("bad")
    with pytest.raises(ParameterError):
        g.table("u", 0)
    g.table("u", 3)
    with pytest.raises(ModelStructureError):
        g.table("u", 3)
    g.add(MSe("U", table_lookup, "t", "tbl:other"))
    g.add(R("R", flow=call(linear_flow, "e", "1.0")))
    g.connect("U", "R")
    with pytest.raises(ModelStructureError, match="unknown table"):
        compile_graph(g)
    h = lag_graph()
    h.output("u", "tbl:u", "1")          # a table is a law argument, not a signal by itself
    with pytest.raises(ModelStructureError, match="law argument"):
        derive_equations(h)
