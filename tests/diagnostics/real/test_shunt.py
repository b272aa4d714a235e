"""The orifice + laminar-shunt leak size: hand calculations, a synthetic round trip, a real slice."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.real.leakage import CyclePoint, cycle_point
from diagnostics.real.relaxation import settled_flow
from diagnostics.real.scoring import score_classes
from diagnostics.real.shunt import (
    MIN_SEPARATION,
    HealthyBaseline,
    ShuntEstimate,
    fit_relaxation,
    fit_shunt,
    leak_threshold,
    plateau_slope,
    reference_flows,
    shunt_estimates,
)
from diagnostics.real.zema import load_1hz, read_records
from diagnostics.timeseries import SeriesRecord
from sim.components.gear_pump import dynamic_viscosity
from sim.errors import InputError
from sim.fluid import Fluid
from tests.real_slices import zema_slice

BAR = 1.0e5
LPM = 1.0 / 60000.0


def test_leak_threshold_splits_at_the_widest_gap() -> None:
    healthy = np.linspace(0.0, 0.05, 30) * LPM
    leaking = np.linspace(0.25, 0.40, 20) * LPM
    thr = leak_threshold(np.concatenate([leaking, healthy]))
    assert thr == pytest.approx(0.5 * (0.05 + 0.25) * LPM)
    with pytest.raises(InputError):
        leak_threshold(np.ones(5))


def test_plateau_slope_of_a_known_pump_line() -> None:
    t = np.arange(60, dtype=np.float64)
    levels = np.repeat([150.0, 160.0, 170.0, 160.0, 155.0, 150.0], 10) * BAR
    q = (8.0 - 0.01 * (levels / BAR - 150.0)) * LPM  # −0.01 l/min per bar
    rec = SeriesRecord("line", t, {"p_pump": levels, "q_work": q}, {"p_pump": "Pa",
                                                                      "q_work": "m^3/s"})
    assert plateau_slope(rec) == pytest.approx(-0.01 * LPM / BAR, rel=1e-9)


def test_reference_flow_moves_healthy_neighbours_to_the_cycles_pressure() -> None:
    pts = [CyclePoint("a", 150 * BAR, 8.0 * LPM, 40.0, 10),
           CyclePoint("b", 160 * BAR, 7.9 * LPM, 40.5, 10),
           CyclePoint("c", 155 * BAR, 7.5 * LPM, 40.2, 10)]
    healthy = np.array([True, True, False])
    slope = -0.01 * LPM / BAR
    ref = reference_flows(pts, healthy, slope)
    # both healthy cycles moved to 155 bar read 7.95 l/min: the median is 7.95
    assert ref[2] == pytest.approx(7.95 * LPM)
    assert ref[0] == pytest.approx(np.median([8.0, 7.9 + 0.1]) * LPM)


def test_the_shunt_comes_back_from_synthetic_cycles() -> None:
    rng = np.random.default_rng(7)
    n = 300
    theta = rng.uniform(35.0, 56.0, n)
    mu = dynamic_viscosity(Fluid(), theta)
    p = rng.uniform(148.0, 156.0, n) * BAR
    size = rng.choice([0.8e-9, 1.3e-9], n)  # two leak settings, independent of θ
    lam = 2.0e-15
    deficit = size * np.sqrt(p) + lam * p / mu
    found = fit_shunt(deficit, p, mu, theta, np.ones(n, dtype=bool), steps=2000)
    assert found == pytest.approx(lam, rel=0.02)
    # without a shunt in the data none is found
    assert fit_shunt(size * np.sqrt(p), p, mu, theta, np.ones(n, dtype=bool)) == 0.0
    with pytest.raises(InputError):
        fit_shunt(deficit[:5], p[:5], mu[:5], theta[:5], np.ones(5, dtype=bool))


def test_leak_size_orders_leakage_classes_on_the_slice() -> None:
    data, labels = load_1hz(zema_slice())
    recs = read_records(data)
    pts = [cycle_point(r) for r in recs]
    mu = dynamic_viscosity(Fluid(), np.array([c.theta for c in pts]))
    est = shunt_estimates(recs, pts, mu)
    assert np.array_equal(est.leaking, labels.leakage > 0)
    med = [float(np.median(est.size[labels.leakage == c])) for c in (0, 1, 2)]
    assert abs(med[0]) < 0.1 * med[1] and med[1] < med[2]
    s = score_classes(est.size, labels.leakage, {})
    assert s.worst_auroc == 1.0
    # the healthy pump line falls with pressure, a few thousandths of l/min per bar
    assert -0.02 * LPM / BAR < est.slope < 0.0
    assert est.shunt >= 0.0
    with pytest.raises(InputError):
        shunt_estimates(recs[:3], pts, mu)


def test_plateaus_after_a_relief_episode_are_left_out_on_request() -> None:
    # start-up at the relief valve (no flow), a working plateau, a relief episode in the
    # middle of the cycle (no flow), a last working plateau: the ZeMA cycles that left the
    # load program (e.g. cycle 502)
    t = np.arange(60, dtype=np.float64)
    p = np.repeat([190.0, 141.0, 188.0, 145.0], 15) * BAR
    q = np.repeat([0.0, 7.4, 1.1, 7.6], 15) * LPM
    rec = SeriesRecord("off-program", t, {"p_pump": p, "q_work": q,
                                          "oil_temperature": np.full(60, 56.0)},
                       {"p_pump": "Pa", "q_work": "m^3/s", "oil_temperature": "degC"})
    first = cycle_point(rec, stop_at_relief=True)
    both = cycle_point(rec)
    # the samples beside a jump are not steady (|dp/dt| from the central difference) and one
    # settle second is dropped: 12 samples of the first plateau, 13 of the last (no jump after)
    assert first.n == 12 and both.n == 25
    assert first.pressure == pytest.approx(141.0 * BAR) and first.flow == pytest.approx(7.4 * LPM)
    assert both.pressure == pytest.approx((12 * 141.0 + 13 * 145.0) / 25 * BAR)
    assert both.flow == pytest.approx((12 * 7.4 + 13 * 7.6) / 25 * LPM)
    # a cycle on its program (no relief episode after the first working plateau) is unchanged
    on = SeriesRecord("on-program", t, {"p_pump": np.repeat([190.0, 141.0, 151.0, 145.0], 15) * BAR,
                                        "q_work": np.repeat([0.0, 7.4, 7.3, 7.4], 15) * LPM,
                                        "oil_temperature": np.full(60, 50.0)},
                      {"p_pump": "Pa", "q_work": "m^3/s", "oil_temperature": "degC"})
    assert cycle_point(on, stop_at_relief=True) == cycle_point(on)


def test_settled_flow_removes_a_known_relaxation() -> None:
    k = np.arange(8, dtype=np.float64)
    q = (7.9 + 0.06 * np.exp(-k / 3.0)) * LPM  # the gas still gives out oil after a fall
    assert settled_flow(q, 3.0) == pytest.approx(7.9 * LPM, rel=1e-12)
    # the plain mean keeps part of the outflow; τ = 0 is that mean
    assert settled_flow(q, 0.0) == pytest.approx(float(q.mean()))
    assert float(q.mean()) > 7.9 * LPM + 0.01 * LPM
    with pytest.raises(InputError):
        settled_flow(q, -1.0)
    with pytest.raises(InputError):
        settled_flow(q[:2], 3.0)


def test_cycle_point_with_relaxation_uses_the_settled_plateau_flows() -> None:
    t = np.arange(60, dtype=np.float64)
    p = np.repeat([190.0, 141.0, 151.0, 161.0], 15) * BAR
    base = np.repeat([0.0, 7.90, 7.84, 7.78], 15)
    bump = np.zeros(60)
    for a, sign in ((15, 1.0), (30, 1.0), (45, -1.0)):  # out after the falls, in after the rise
        bump[a:a + 15] = sign * 0.05 * np.exp(-np.arange(15) / 2.0)
    rec = SeriesRecord("relax", t, {"p_pump": p, "q_work": (base + bump) * LPM,
                                    "oil_temperature": np.full(60, 45.0)},
                       {"p_pump": "Pa", "q_work": "m^3/s", "oil_temperature": "degC"})
    pt = cycle_point(rec, relaxation=2.0)
    plain = cycle_point(rec)
    # the settled flows are the pump's own: their sample-weighted mean
    plats = [(17, 29), (32, 44), (47, 60)]
    n = np.array([b - a for a, b in plats], dtype=np.float64)
    assert pt.flow == pytest.approx(float(np.dot(n, [7.90, 7.84, 7.78]) / n.sum()) * LPM, rel=1e-9)
    assert pt.pressure == plain.pressure and pt.n == plain.n == int(n.sum())
    assert cycle_point(rec, relaxation=2.0, max_plateaus=1).flow == pytest.approx(7.90 * LPM)


def test_relaxation_time_is_found_without_labels_on_the_slice() -> None:
    data, labels = load_1hz(zema_slice())
    recs = read_records(data)

    def mu_of(th: np.ndarray) -> np.ndarray:
        return np.asarray(dynamic_viscosity(Fluid(), th), dtype=np.float64)

    grid = (0.0, 2.0, 4.0)
    tau, rho = fit_relaxation(recs, mu_of, taus=grid)
    assert tau in grid and rho.shape == (3,)
    assert float(rho[grid.index(tau)]) == float(np.nanmin(rho))
    pts = [cycle_point(r, stop_at_relief=True, relaxation=tau) for r in recs]
    est = shunt_estimates(recs, pts, mu_of(np.array([c.theta for c in pts])))
    assert score_classes(est.size, labels.leakage, {}).worst_auroc == 1.0
    with pytest.raises(InputError):
        fit_relaxation(recs, mu_of, taus=())


def _span() -> tuple[list[SeriesRecord], list[CyclePoint], np.ndarray, np.ndarray]:
    """The temperature-span slice: 18 healthy and 18 severely leaking cycles, 35-58 °C."""
    from tests.real_slices import zema_span_slice

    data, labels = load_1hz(zema_span_slice())
    recs = read_records(data)
    pts = [cycle_point(r) for r in recs]
    mu = np.asarray(dynamic_viscosity(Fluid(), np.array([c.theta for c in pts])))
    return recs, pts, mu, np.asarray(labels.leakage).astype(int)


def test_a_batch_of_one_class_is_refused_without_a_baseline_and_read_with_one() -> None:
    """A batch of healthy cycles alone (or leaking ones alone) cannot be its own healthy
    reference (a real-data analyst's pass: 11 of 100 healthy cycles flagged; a severe leak
    read at 15 % of its size).  Against a baseline of cycles known healthy, each cycle's
    leak size is its own: the same whatever other cycles the batch holds."""
    recs, pts, mu, lab = _span()
    healthy = np.flatnonzero(lab == 0)
    leaking = np.flatnonzero(lab == 2)
    with pytest.raises(InputError) as refused:
        shunt_estimates([recs[i] for i in healthy], [pts[i] for i in healthy], mu[healthy])
    assert refused.value.field == "baseline"
    assert "no separate leaking group" in refused.value.message
    # (leaking cycles alone split at their own widest gap, which no check on the batch can
    # tell from a healthy/leaking split: that is what the baseline is for)
    # the baseline: two healthy cycles in three; the batches below never hold them
    base_i, rest_h = healthy[np.arange(healthy.size) % 3 != 2], healthy[2::3]
    base = HealthyBaseline([recs[i] for i in base_i], [pts[i] for i in base_i])

    def read(idx: np.ndarray, shunt: float | None = None) -> ShuntEstimate:
        return shunt_estimates([recs[i] for i in idx], [pts[i] for i in idx], mu[idx],
                               baseline=base, shunt=shunt)

    mixed = read(np.concatenate([rest_h, leaking]))
    assert mixed.reference == "baseline"
    # a cycle with no baseline cycle within ±1 °C has no reference: no size, not leaking
    covered = np.isfinite(mixed.deficit)
    assert covered.sum() >= 20 and np.isnan(mixed.size[~covered]).all()
    assert not mixed.leaking[: rest_h.size].any()
    assert np.array_equal(mixed.leaking[rest_h.size:], covered[rest_h.size:])
    # ... and it is said (an analyst's pass: 169 of 200 cycles NaN and "not leaking", silent)
    (note,) = mixed.notes
    assert f"{int((~covered).sum())} of {covered.size} cycles" in note and "not judged" in note
    # a baseline that covers none of the batch is refused, naming both ranges
    cold = np.array([p.theta for p in pts]) < np.median([p.theta for p in pts]) - 3.0
    with pytest.raises(InputError) as uncovered:
        shunt_estimates([recs[i] for i in np.flatnonzero(~cold)],
                        [pts[i] for i in np.flatnonzero(~cold)], mu[~cold],
                        baseline=HealthyBaseline([recs[i] for i in np.flatnonzero(cold)],
                                                 [pts[i] for i in np.flatnonzero(cold)]))
    assert uncovered.value.field == "baseline" and "°C" in uncovered.value.message
    # leaking cycles alone, with the shunt the mixed batch found: the same sizes
    alone = read(leaking, shunt=mixed.shunt)
    np.testing.assert_array_equal(alone.leaking, mixed.leaking[rest_h.size:])
    np.testing.assert_allclose(alone.size, mixed.size[rest_h.size:], rtol=1e-12)
    # healthy cycles alone: none leaks, their sizes those of the mixed batch (≈ 0)
    quiet = read(rest_h)
    assert not quiet.leaking.any() and quiet.shunt == 0.0
    np.testing.assert_allclose(quiet.size, mixed.size[: rest_h.size], rtol=1e-12)
    assert np.nanmax(np.abs(quiet.size)) < 0.1 * np.nanmedian(alone.size)
    # the severe leak, as the whole slice read without a baseline
    whole = shunt_estimates(recs, pts, mu)
    assert whole.reference == "batch" and whole.separation >= MIN_SEPARATION
    assert np.nanmedian(alone.size) == pytest.approx(np.median(whole.size[leaking]), rel=0.15)
    with pytest.raises(InputError) as small:
        shunt_estimates(recs, pts, mu, baseline=HealthyBaseline(base.records[:5],
                                                                 base.points[:5]))
    assert small.value.field == "baseline"
