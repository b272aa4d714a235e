"""Latin hypercube and orthogonal plans; LHS gives the lower S on the virtual bench."""

from __future__ import annotations

import numpy as np
import pytest

from diagnostics.pump import (
    FLOW_TERMS,
    context_from_bench,
    design_columns,
    fit_ols,
    latin_hypercube_plan,
    orthogonal_plan,
    run_virtual_bench,
)
from sim.components.gear_pump import GearPump
from sim.components.gear_pump_map import MAP_OMEGA_RANGE, MAP_P_RANGE
from sim.errors import InputError

TERMS = ("disp", "lam_wilson", "lam_manring16", "turb_schlosser", "comp_zarotti")


def test_latin_hypercube_has_one_point_per_stratum_and_is_seeded() -> None:
    n = 25
    dp, w = latin_hypercube_plan(n, MAP_P_RANGE, MAP_OMEGA_RANGE, seed=3)
    for x, (lo, hi) in ((dp, MAP_P_RANGE), (w, MAP_OMEGA_RANGE)):
        strata = np.floor((x - lo) / (hi - lo) * n).astype(int)
        assert sorted(strata) == list(range(n))
    dp2, w2 = latin_hypercube_plan(n, MAP_P_RANGE, MAP_OMEGA_RANGE, seed=3)
    np.testing.assert_array_equal(dp, dp2)
    np.testing.assert_array_equal(w, w2)
    dp3, _ = latin_hypercube_plan(n, MAP_P_RANGE, MAP_OMEGA_RANGE, seed=3, corner_points=4)
    assert dp3.size == n + 4 and np.all(dp3[n:] >= 0.9 * MAP_P_RANGE[1])


def test_orthogonal_plan_is_a_full_factorial_with_the_extremes() -> None:
    dp, w = orthogonal_plan(6, 4, MAP_P_RANGE, MAP_OMEGA_RANGE)
    assert dp.size == 24
    assert sorted(set(dp)) == pytest.approx(list(np.linspace(*MAP_P_RANGE, 6)))
    assert sorted(set(w)) == pytest.approx(list(np.linspace(*MAP_OMEGA_RANGE, 4)))
    with pytest.raises(InputError) as e:
        orthogonal_plan(1, 4, MAP_P_RANGE, MAP_OMEGA_RANGE)
    assert e.value.field == "n_p"
    with pytest.raises(InputError) as e:
        latin_hypercube_plan(10, (3e7, 2e6), MAP_OMEGA_RANGE)
    assert e.value.field == "p_range"


def test_lhs_gives_a_lower_mean_standard_error_than_orthogonal(pump: GearPump) -> None:
    seeds, n_p, n_w = 200, 6, 5
    diffs = []
    for s in range(seeds):
        rng = np.random.default_rng(100 + s)
        S = {}
        for name, (dp, w) in (
                ("orth", orthogonal_plan(n_p, n_w, MAP_P_RANGE, MAP_OMEGA_RANGE)),
                ("lhs", latin_hypercube_plan(n_p * n_w, MAP_P_RANGE, MAP_OMEGA_RANGE,
                                             seed=rng))):
            b = run_virtual_bench(pump, dp, w, (22.0, 60.0), replicates=2, seed=rng,
                                  with_torque=False)
            cols = design_columns(FLOW_TERMS, context_from_bench(b, pump.D))
            S[name] = fit_ols(cols, b.q, TERMS).S
        diffs.append(S["lhs"] - S["orth"])
    d = np.asarray(diffs)
    # paired over seeds: LHS lower, by more than two standard errors of the mean difference
    assert d.mean() < -2 * d.std(ddof=1) / np.sqrt(seeds)


def test_a_negative_corner_count_is_refused() -> None:
    with pytest.raises(InputError) as e:
        latin_hypercube_plan(10, (2e6, 2e7), (60.0, 250.0), corner_points=-3)
    assert e.value.field == "corner_points"
