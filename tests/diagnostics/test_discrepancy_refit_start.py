"""The output-error re-fit when its start cannot be simulated (:func:`diagnostics.
discrepancy.refit.refit`)."""

from __future__ import annotations

from typing import Any

import pytest

from diagnostics.discrepancy import refit as refit_module
from sim.errors import SolverLimitError
from sim.rigs import reference_rig_document


def test_a_start_the_solver_cannot_simulate_raises_the_solver_error_not_a_key_error(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A 10-seed study stopped on ``KeyError: 0.1``: the re-fit's residual function fell back
    to a penalty vector sized by the first evaluation, and the first evaluation was the one
    that failed (RODAS4's step fell below round-off).  The failure must reach the caller as
    the solver's own error, which the workflow's callers count as a failed case."""

    def fails(*args: Any, **kwargs: Any) -> Any:
        raise SolverLimitError("rtol: working phase: the step size fell below round-off")

    monkeypatch.setattr(refit_module, "residual_parts", fails)
    with pytest.raises(SolverLimitError):
        refit_module.refit(reference_rig_document(), {"entrained_air.alpha": 2.5e-4}, [],
                           ["P1"], {"P1": 1e4}, max_nfev=5)


def test_a_candidate_whose_refit_cannot_be_simulated_is_rejected_and_the_case_goes_on(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Seal friction hidden in the data is the equation error's choice; when its output-error
    re-fit hits the solver's limit the workflow does not stop: the candidate is not
    confirmed, the answer says why (the solver's own message), and nothing is named."""
    from diagnostics.discrepancy import confirm as confirm_module
    from diagnostics.discrepancy import discover
    from tests.diagnostics.test_discrepancy import _records, _with

    def fails(*args: Any, **kwargs: Any) -> Any:
        raise SolverLimitError("rtol: working phase: the step size fell below round-off")

    monkeypatch.setattr(confirm_module, "output_error_refit", fails)
    monkeypatch.setattr(confirm_module, "tell_apart", fails)
    recs = _records(_with("seal_friction_pressure", "k_p", 1.5e-5, "m^2"), 2)
    d = discover(reference_rig_document(), recs, bootstrap=10)
    assert d.named == []
    assert d.verdict != "named"
    assert "could not be simulated" in d.message
    assert "seal_friction_pressure (rtol: working phase: the step size fell below" in d.message
