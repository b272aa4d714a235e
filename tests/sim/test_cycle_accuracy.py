"""Noise-accurate cycles (issue 17): RODAS4 against independent and converged references,
the error estimate against the true error, solver limits (issue 16 item 3)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.work_precision import _errors, _reference, _scipy_cycle, stribeck_rig
from sim.cycle import PHASES, integrate_phases, phase_params, run_cycle, sampled_outputs
from sim.errors import ParameterError, SolverLimitError
from sim.rigs import Rig, reference_rig
from sim.solver.limits import SolverLimits
from sim.solver.noise import NoiseAccuracy


@pytest.fixture(scope="module")
def rig() -> Rig:
    return reference_rig()


@pytest.fixture(scope="module")
def converged(rig: Rig) -> list[tuple[np.ndarray, np.ndarray]]:
    """RODAS4 at rtol 1e-9 on a 1 kHz grid (agrees with scipy Radau at 1e-9 to 1e-5σ)."""
    return _reference(rig, 1e-9)


def test_rodas4_agrees_with_scipy_radau(rig: Rig) -> None:
    # an independent implicit Runge-Kutta code on the same equations and events
    radau = _scipy_cycle(rig, "Radau", 1e-6)
    ours = _reference(rig, 1e-8)
    err = _errors(rig, ours, radau)
    assert err["v"] < 0.005 and err["P"] < 0.005 and err["Q"] < 0.005


def test_noise_accurate_cycle_meets_the_targets_and_its_estimate_is_honest(
        rig: Rig, converged: list[tuple[np.ndarray, np.ndarray]]) -> None:
    res = run_cycle(rig, method="rodas4", sample_rate=1000.0)
    rep = res.solver
    assert rep is not None and rep.error_sigma is not None and rep.target_sigma is not None
    assert all(rep.error_sigma[n] <= rep.target_sigma[n] for n in rep.error_sigma)
    assert rep.target_sigma["v"] == 0.3 and rep.target_sigma["P_pump"] == 0.1
    # the true error against the converged run, per output in σ
    frame = res.timeseries
    assert frame is not None
    runs = [(frame.loc[frame.phase == ph, "t [s]"].to_numpy(),
             frame.loc[frame.phase == ph].iloc[:, 2:].to_numpy()) for ph in PHASES]
    true = _errors(rig, runs, converged)
    assert true["v"] <= 0.3 and true["P"] <= 0.1 and true["Q"] <= 0.1
    est_v = rep.error_sigma["v"]
    est_p = max(rep.error_sigma[n] for n, u in zip(rig.model.output_names,
                                                   rig.model.output_units, strict=True)
                if u == "Pa")
    # the estimate neither hides the error nor overstates it wildly
    assert true["v"] / 3 <= est_v <= 3 * true["v"]
    assert true["P"] / 3 <= est_p <= 3 * true["P"]


def test_a_tighter_target_gives_a_tighter_tolerance(rig: Rig) -> None:
    loose = run_cycle(rig, method="rodas4", sample_rate=1000.0, timeseries=False)
    tight = run_cycle(rig, method="rodas4", sample_rate=1000.0, timeseries=False,
                      accuracy=NoiseAccuracy(fraction={"v": 0.01}))
    assert loose.solver is not None and tight.solver is not None
    assert tight.solver.rtol < loose.solver.rtol
    assert tight.solver.error_sigma is not None and tight.solver.error_sigma["v"] <= 0.01


def test_sampled_output_is_on_the_grid_and_summaries_agree_with_ros2(rig: Rig) -> None:
    r4 = run_cycle(rig, method="rodas4", rtol=1e-6, sample_rate=1000.0)
    r2 = run_cycle(rig, method="ros2", rtol=1e-6, timeseries=False)
    assert r4.timeseries is not None
    t = r4.timeseries["t [s]"].to_numpy()
    np.testing.assert_allclose(np.diff(t), 1e-3, rtol=0, atol=1e-12)
    for ph4, ph2 in ((r4.working, r2.working), (r4.return_, r2.return_)):
        assert ph4["speed"] == pytest.approx(ph2["speed"], rel=1e-5)
        assert ph4["P_pump"] == pytest.approx(ph2["P_pump"], rel=1e-3)


def test_the_stiff_stribeck_variant_runs_noise_accurate(rig: Rig) -> None:
    variant = stribeck_rig(rig)
    res = run_cycle(variant, method="rodas4", sample_rate=1000.0, timeseries=False)
    assert res.working.completed and res.return_.completed
    assert res.solver is not None and res.solver.error_sigma is not None
    assert res.solver.error_sigma["v"] <= 0.3


def test_tight_tolerances_run_with_no_buffer_limit(rig: Rig) -> None:
    # issue 16 item 3: rtol 1e-7 filled ROS2's fixed 200,000-row buffer
    res = run_cycle(rig, method="rodas4", rtol=1e-8, timeseries=False)
    assert res.working.completed and res.return_.completed
    p = phase_params(rig, "working", None, rig.default_condition())
    y0 = rig.model.initial_state(p)
    small = rig.model.integrate(y0, p, 0.05, rtol=1e-6, capacity=100)
    big = rig.model.integrate(y0, p, 0.05, rtol=1e-6)
    # the ROS2 buffer is copied out and refilled: the run goes on (restarted steps differ
    # only in the step-size history)
    assert small.success and small.t[-1] == 0.05 and small.t.size > 100
    assert abs(small.t.size - big.t.size) < 0.01 * big.t.size
    diff = np.abs(small.y[-1] - big.y[-1])
    assert np.all(diff <= 1e-5 * np.abs(big.y[-1]) + 1e-3 * rig.model.scale)


@pytest.mark.parametrize(("limits", "words"), [
    (SolverLimits(max_steps=300, chunk_steps=100), "step limit"),
    (SolverLimits(max_sim_time=1.0), "simulated time"),
    (SolverLimits(wall_clock=1e-9, chunk_steps=50), "wall-clock"),
])
def test_limits_give_a_solver_limit_error_with_the_reason(rig: Rig, limits: SolverLimits,
                                                          words: str) -> None:
    with pytest.raises(SolverLimitError) as info:
        run_cycle(rig, method="rodas4", rtol=1e-6, limits=limits, sample_rate=1000.0)
    assert words in info.value.message


def test_ros2_has_no_sampling(rig: Rig) -> None:
    with pytest.raises(ParameterError) as info:
        run_cycle(rig, method="ros2", sample_rate=1000.0)
    assert info.value.field == "sample_rate"


def test_companion_times_are_the_runs_own(rig: Rig) -> None:
    params = [phase_params(rig, ph, None, rig.default_condition()) for ph in PHASES]
    main = integrate_phases(rig, params, method="rodas4", rtol=1e-5)
    comp = integrate_phases(rig, params, method="rodas4", rtol=1e-4,
                            times=[r.res.t for r in main])
    for (tm, _), (tc, _) in zip(sampled_outputs(main, rig), sampled_outputs(comp, rig),
                                strict=True):
        # all of the companion's times are the run's; it misses only those between the
        # two runs' phase switches
        assert np.isin(tc, tm).all() and tc.size >= 0.99 * tm.size


def test_rodas4_agrees_with_sundials_cvode(rig: Rig) -> None:
    # SUNDIALS CVODE (variable-order BDF) on the same compiled right-hand side: the
    # working phase up to 2.0 s (its end-of-stroke event is at ~2.42 s)
    from sksundae.cvode import CVODE

    m = rig.model
    p = phase_params(rig, "working", None, rig.default_condition())
    y0 = m.initial_state(p)
    grid = np.arange(0.0, 2.0 + 1e-12, 1e-3)

    def f(t: float, y: np.ndarray, yp: np.ndarray) -> None:
        m.module.rhs(t, y, p, yp)

    sol = CVODE(f, method="BDF", rtol=1e-8, atol=1e-8 * m.scale).solve(grid, y0)
    assert sol.success
    ours = m.integrate(y0, p, 2.0, rtol=1e-9, method="rodas4", times=grid)
    assert ours.t.size == grid.size
    cv = m.outputs(grid, np.ascontiguousarray(sol.y), p)
    r4 = m.outputs(ours.t, ours.y, p)
    diff = dict(zip(m.output_names, np.abs(cv - r4).max(axis=0), strict=True))
    assert diff["v"] < 0.01 * 3.2e-4
    assert diff["P_pump"] < 0.01 * 25e3 and diff["P1"] < 0.01 * 25e3
    assert diff["Q_meter_B"] < 0.01 * 2.33e-6


@pytest.mark.parametrize("sample", [False, True])
def test_chunked_integration_equals_one_call(rig: Rig, sample: bool) -> None:
    # the wall-clock checks split the compiled loop into chunks; the result is the same
    p = phase_params(rig, "working", None, rig.default_condition())
    y0 = rig.model.initial_state(p)
    grid = np.arange(0.0, 0.3, 1e-4) if sample else None
    one = rig.model.integrate(y0, p, 0.3, rtol=1e-6, method="rodas4", times=grid)
    many = rig.model.integrate(y0, p, 0.3, rtol=1e-6, method="rodas4", times=grid,
                               limits=SolverLimits(chunk_steps=7))
    # each time once, in order; a resumed call restarts the step-size controller, so the
    # two runs agree to the tolerance, not bit for bit
    assert np.all(np.diff(many.t) > 0) and many.t[0] == 0.0
    assert many.steps > one.steps / 2
    if sample:
        np.testing.assert_array_equal(one.t, many.t)
    tol = 1e-4 * (np.abs(one.y_final) + rig.model.scale)
    assert np.all(np.abs(one.y_final - many.y_final) <= tol)
