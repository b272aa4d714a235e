"""The result of commissioning (:func:`diagnostics.commissioning.commission`): each fitted
parameter with its interval and what the records could pin down, and the fit's test."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["PRIOR_LIMIT", "CommissionedParameter", "Commissioning"]

#: a fitted value beyond this many prior σ of ln θ from the document's is not stored
#: unless asked (:attr:`Commissioning.beyond_prior`) [-]
PRIOR_LIMIT = 3.0


@dataclass
class CommissionedParameter:
    """One fitted parameter.

    Attributes
    ----------
    name
        Graph parameter (``"cylinder.Lc"``).
    description
        What it is.
    before
        Value in the document [SI].
    value, low, high
        Estimate and 95 % interval [SI]; a pinned parameter's interval integrates the
        parameters the records left open (:mod:`diagnostics.commissioning_nuisance`).
    prior_sd, posterior_sd
        Standard deviations of ln θ before and after the records, the latter linearised
        (Laplace) [-].
    identifiable
        Whether the records pinned it down (posterior σ ≤ half the prior σ).
    correlated_with
        Parameters whose posterior correlation with this one is ≥ 0.8 in magnitude.
    prior_shift
        How far the estimate moved from the document's value, in prior standard deviations
        of ln θ [-]; beyond :data:`PRIOR_LIMIT` the document's uncertainty does not allow
        it (:attr:`Commissioning.beyond_prior`).
    """

    name: str
    description: str
    before: float
    value: float
    low: float
    high: float
    prior_sd: float
    posterior_sd: float
    identifiable: bool
    correlated_with: list[str] = field(default_factory=list)
    prior_shift: float = 0.0


@dataclass
class Commissioning:
    """Result of :func:`~diagnostics.commissioning.commission`.

    Attributes
    ----------
    rig
        Rig name.
    parameters
        The fitted parameters, in :data:`~diagnostics.commissioning.COMMISSIONED` order (those asked for).
    chi2
        χ² of the readings at the estimate [-].
    n_observations
        Number of readings [-].
    n_records
        Number of records [-].
    iterations
        Levenberg-Marquardt iterations [-].
    statements
        What a reader must know (what could not be pinned down and why; first, when the
        fit does not explain the records, that and the readings that disagree most).
    dof
        Degrees of freedom of the χ² test: readings less the effective number of fitted
        parameters (Σ 1 − posterior/prior variance) [-].
    limit
        χ²_{1-α}(dof) at the goodness-of-fit test's level
        (:data:`diagnostics.goodness.TEST_LEVEL`) [-].
    consistent
        Whether χ² ≤ ``limit``: the records are those of one healthy rig of the
        document's family.  When not, the service stores nothing.
    disagreements
        (record index, reading, deviation [σ]) beyond 3 σ at the fit, worst first.
    """

    rig: str
    parameters: list[CommissionedParameter]
    chi2: float
    n_observations: int
    n_records: int
    iterations: int
    statements: list[str] = field(default_factory=list)
    dof: float = math.nan
    limit: float = math.inf
    consistent: bool = True
    disagreements: list[tuple[int, str, float]] = field(default_factory=list)

    def values(self) -> dict[str, float]:
        """Fitted values of the parameters the records pinned down [SI]."""
        return {p.name: p.value for p in self.parameters if p.identifiable}

    @property
    def beyond_prior(self) -> list[str]:
        """The pinned-down parameters that moved more than :data:`PRIOR_LIMIT` prior σ."""
        return [p.name for p in self.parameters
                if p.identifiable and abs(p.prior_shift) > PRIOR_LIMIT]
