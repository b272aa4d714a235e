"""Effects below the practical size, confirmed by re-simulation
(:func:`diagnostics.discrepancy.confirm.confirm_small`).

On the hidden-effect bench's design (the study's seed of its second case) a
pressure-dependent seal friction at the bench's 4 σ is significant in the piston-force
balance (|t| ≈ 68) with an RMS below the practical size (0.1 % of the stall force), while
the held-out outputs are 5-12 σ off: the balance chooses nothing, the second look re-fits
it by re-simulation and names it.
"""

from __future__ import annotations

import math
from typing import Any

import pytest

from benchmarks.discrepancy_study import _case, _doc_with
from diagnostics.discrepancy.balances import BalanceData
from diagnostics.discrepancy.selection import PRACTICAL, select
from diagnostics.discrepancy.transient import SIGNIFICANT_T, is_significant
from tests.diagnostics.test_discrepancy_practical import bench_balance
from tests.diagnostics.test_discrepancy_transient import assert_named_alone

#: the bench's 4 σ seal-friction coefficient: 4 × the calibrated 1 σ of 1.93399e-6 [m²]
K_SEAL = 7.73596e-6


def _piston_balance(doc: dict[str, Any], seed: int) -> BalanceData:
    return bench_balance(doc, seed, "piston_force")


def test_a_significant_single_below_the_practical_size_is_kept_for_the_second_look() -> None:
    d = _piston_balance(_doc_with("seal_friction_pressure", K_SEAL), 1007)
    sel = select(d, bootstrap=0)
    assert sel.chosen is None
    assert sel.small[0].terms[0].effect == "seal_friction_pressure"
    term = sel.small[0].terms[0]
    assert term.rms_contribution < PRACTICAL * d.full_scale
    assert abs(term.t) > 10 and term.plausible
    assert term.coefficient == pytest.approx(K_SEAL, rel=0.2)


def test_without_an_effect_the_piston_balance_keeps_nothing_below_the_practical_size() -> None:
    sel = select(_piston_balance(_doc_with(None), 1007), bootstrap=0)
    assert sel.chosen is None and sel.small == []


def test_seal_friction_below_the_practical_size_is_named_by_re_simulation() -> None:
    """Named in its balance, within 10 % of the truth and inside its interval, the rig
    document carrying it; the message says it was below the practical size and how much
    the held-out gap shrank."""
    d = _case(_doc_with("seal_friction_pressure", K_SEAL), 1007)
    assert_named_alone(d, "seal_friction_pressure", "k_p", K_SEAL, 0.10)
    assert d.named[0].balance == "piston_force"
    assert "named below the practical size" in d.message
    piston = next(b for b in d.to_dict()["balances"] if b["balance"] == "piston_force")
    assert piston["chosen"] == []
    assert (piston["candidates"]["seal_friction_pressure"]["rms_contribution"]
            < piston["practical_size"])


def test_a_re_fitted_coefficient_is_significant_only_with_an_error_the_fit_could_estimate(
) -> None:
    # the output-error error is NaN when the Jacobian is singular or the slow strokes' χ²
    # is flat: the records do not determine the coefficient, so it is not confirmed
    assert not is_significant(5.0, math.nan)
    assert not is_significant(5.0, math.inf)
    assert is_significant(-5.0, 5.0 / (SIGNIFICANT_T + 0.1))
    assert not is_significant(5.0, 5.0 / (SIGNIFICANT_T - 0.1))


def test_nested_fits_alike_take_the_smaller_of_lowest_bic() -> None:
    """Re-fitted options the data cannot separate (``group`` by rising BIC, as
    :func:`~diagnostics.discrepancy.refit.tell_apart` returns it): a pair and its two
    singles alike take the single of the lower BIC — whatever the equation error's order
    of the options — and the pair that contains it is no rival."""
    from diagnostics.discrepancy.confirm import nested_pick

    pair = {"seal_friction_pressure.k_p": 1e-5, "load_scale.k_F": 0.03}
    seal, load = {"seal_friction_pressure.k_p": 1e-5}, {"load_scale.k_F": 0.03}
    starts = [seal, load, pair]  # the equation error's order: seal friction first
    # the pair best by BIC, then the stated-load single, then seal friction
    assert nested_pick(2, [2, 1, 0], starts) == (1, [1, 0])
    assert nested_pick(2, [2, 0, 1], starts) == (0, [0, 1])
    # a single that is not nested in the best stays the best's rival
    assert nested_pick(1, [1, 0], starts) == (1, [1, 0])
    # the pair alone within reach: taken
    assert nested_pick(2, [2], starts) == (2, [2])


def test_the_two_nearest_singles_are_re_fitted_together_too() -> None:
    from diagnostics.discrepancy.confirm import with_pair
    from diagnostics.discrepancy.selection import Fit, Term

    def single(effect: str) -> Fit:
        return Fit([Term(effect, 1.0, 0.1, 10.0, 1e-6, 1.0, True)], 0.0, 0.0, True)

    options = with_pair([single("a"), single("b"), single("c")])
    assert [{t.effect for t in f.terms} for f in options] == [{"a"}, {"b"}, {"c"}, {"a", "b"}]
    assert with_pair(options) == options  # the pair is there already
    assert with_pair([single("a")]) == [single("a")]
