"""The open parameters integrated into the pinned ones' commissioning intervals
(diagnostics/commissioning_nuisance.py)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pytest
from scipy.stats import norm

from diagnostics.commissioning_nuisance import marginal_intervals
from sim.errors import SimulationError

Arr = npt.NDArray[np.float64]


def _map(residuals, s: Arr, z0: Arr) -> tuple[Arr, Arr]:  # type: ignore[no-untyped-def]
    """MAP and Laplace covariance of a small problem by Gauss-Newton (test helper)."""
    z = z0.copy()
    for _ in range(50):
        r = residuals(z)
        jac = np.column_stack([(residuals(z + 1e-6 * e) - r) / 1e-6 for e in np.eye(z.size)])
        h = jac.T @ jac + np.diag(1.0 / s**2)
        z = z - np.linalg.solve(h, jac.T @ r + z / s**2)
    return z, np.linalg.inv(h)


def test_a_law_linear_in_z_gives_the_laplace_interval_back() -> None:
    """Readings linear in z: every conditional posterior is Gaussian with the same
    variance and a mean linear in the open parameter, so the mixture is the Laplace
    Gaussian (its 3-node quadrature matches that Gaussian's moments to the fifth; its
    2.5 % quantile lies within 1 % of the half-width)."""
    a = np.array([[4.0, 1.5], [2.0, 1.0], [1.0, 0.2]])
    b = np.array([1.0, 0.3, -0.2])
    s = np.array([0.5, 0.7])

    def residuals(z: Arr) -> Arr:
        return a @ z - b

    z, cov = _map(residuals, s, np.zeros(2))
    pinned = [True, False]
    (low, high), = marginal_intervals(residuals, z, s, cov, pinned).values()
    half = 1.96 * np.sqrt(cov[0, 0])
    assert low == pytest.approx(z[0] - half, abs=0.01 * half)
    assert high == pytest.approx(z[0] + half, abs=0.01 * half)


def test_an_open_parameter_entering_as_exp_z_skews_the_pinned_interval() -> None:
    """A force balance F = Fu + Kf·v read at one speed: Fu = θ₀·e^{z₀} pinned by a precise
    reading of the sum, Kf = e^{z₁} open (its prior alone).  Fu's marginal carries Kf's
    lognormal spread — the mixture reaches further down than the linearised interval
    (a large Kf leaves less for Fu), and its ends are those of the exact marginal, found
    here by sampling Kf's posterior and re-solving Fu."""
    v, total, sigma = 0.1, 1.1, 0.005
    s = np.array([0.5, 0.7])

    def residuals(z: Arr) -> Arr:
        return np.array([(np.exp(z[0]) + np.exp(z[1]) * v - total) / sigma])

    z, cov = _map(residuals, s, np.zeros(2))
    assert np.sqrt(cov[0, 0]) <= 0.5 * s[0] < np.sqrt(cov[1, 1])  # Fu pinned, Kf open
    (low, high), = marginal_intervals(residuals, z, s, cov, [True, False]).values()
    lap = (z[0] - 1.96 * np.sqrt(cov[0, 0]), z[0] + 1.96 * np.sqrt(cov[0, 0]))
    assert low < lap[0] - 0.01
    # the exact marginal: Kf from its posterior (its prior here), Fu = ln(total − Kf·v)
    kf = np.exp(z[1] + np.sqrt(cov[1, 1]) * norm.ppf(np.linspace(0.0005, 0.9995, 2000)))
    fu = np.log(np.clip(total - kf * v, 1e-9, None))
    exact = np.quantile(fu, [0.025, 0.975])
    assert low == pytest.approx(exact[0], abs=0.25 * (exact[1] - exact[0]))
    assert high == pytest.approx(exact[1], abs=0.25 * (exact[1] - exact[0]))


def test_nothing_open_or_nothing_pinned_leaves_the_laplace_intervals() -> None:
    def residuals(z: Arr) -> Arr:
        return z - 1.0

    s, z, cov = np.ones(2), np.full(2, 0.5), np.eye(2) * 0.5
    assert marginal_intervals(residuals, z, s, cov, [True, True]) == {}
    assert marginal_intervals(residuals, z, s, cov, [False, False]) == {}


def test_a_grid_node_without_a_steady_point_falls_back_to_fewer_nodes_then_laplace() -> None:
    """Where the rig has no steady point at a node of the 5-node grid (an open parameter
    ±2.86 σ away) the 3-node grid (±1.73 σ) is used; where that fails too the caller keeps
    the Laplace interval (an empty answer)."""
    s = np.array([0.5, 0.7])
    z, cov = np.zeros(2), np.array([[0.01, -0.02], [-0.02, 0.45]])

    def beyond(limit: float):  # type: ignore[no-untyped-def]
        def residuals(zz: Arr) -> Arr:
            if zz[1] > limit:
                raise SimulationError("no steady point")
            return np.array([(zz[0] + 0.5 * zz[1]) / 0.05])
        return residuals

    got = marginal_intervals(beyond(1.5), z, s, cov, [True, False])  # 3 nodes reach 1.16
    assert set(got) == {0} and got[0][0] < 0.0 < got[0][1]
    assert marginal_intervals(beyond(0.2), z, s, cov, [True, False]) == {}
