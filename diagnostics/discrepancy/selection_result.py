"""What the discrepancy selection returns (:mod:`~diagnostics.discrepancy.selection`): a
candidate term, a fitted subset, and the outcome in one balance with the JSON-able views the
report and the HTTP answer use."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["Fit", "Selection", "Term"]

Arr = npt.NDArray[np.float64]


@dataclass
class Term:
    """One candidate term in a fitted subset."""

    effect: str
    coefficient: float
    stderr: float
    t: float
    p: float
    rms_contribution: float
    plausible: bool


@dataclass
class Fit:
    """A fitted subset."""

    terms: list[Term]
    bic: float
    rss: float
    admissible: bool
    reasons: list[str] = field(default_factory=list)
    #: fails only the practical-size check (every term significant, signs physical)
    small: bool = False


@dataclass
class Selection:
    """Outcome of the selection in one balance.

    Attributes
    ----------
    balance
        Balance name.
    chosen
        The chosen subset, or ``None`` (no effect / no admissible explanation).
    base_bic, bic_gain
        BIC of the re-fitted base model and the chosen subset's improvement on it.
    competing
        Other admissible subsets within ΔBIC < 2 (effect names).
    ambiguity
        Groups of candidates that this test design cannot tell apart (each group includes
        ``"base"`` when the column lies in the base columns' span).
    inclusion
        Bootstrap inclusion frequency of each chosen effect.
    detectable
        Minimum detectable RMS contribution of each candidate [balance unit].
    singles
        The single-term fits by effect (t, p, coefficient) for the report.
    base_coefficients
        Re-fitted base coefficients by column name [SI].
    residual
        Residual of the chosen (or base) fit at the kept samples [balance unit].
    near
        Admissible subsets other than the chosen one within ΔBIC < :data:`NEAR_BIC`, and
        admissible singles whose column correlates with a chosen term's at ≥
        :data:`NEAR_CORR` once the base columns are projected out, best first (the
        competing ones included): explanations the equation error hardly separates
        (piston clearance vs viscosity law: 0.991 on the study's design).
    """

    balance: str
    unit: str
    chosen: Fit | None
    base_bic: float
    bic_gain: float
    competing: list[list[str]]
    ambiguity: list[list[str]]
    inclusion: dict[str, float]
    detectable: dict[str, float]
    singles: dict[str, Term]
    base_coefficients: dict[str, float]
    residual: Arr
    base_residual: Arr
    full_scale: float
    near: list[Fit] = field(default_factory=list)
    #: singles that fail only the practical size, with the BIC margin, best first: tried
    #: in output-error form when nothing else explains a held-out gap above the noise
    #: (:mod:`~diagnostics.discrepancy.confirm`)
    small: list[Fit] = field(default_factory=list)
    #: the balance's :attr:`~diagnostics.discrepancy.balances.BalanceData.noise_floor`
    noise_floor: float = 0.0
    #: candidates this design cannot identify, with the most their largest plausible
    #: coefficient moves the balance anywhere [balance unit] (:func:`_reach`): their
    #: fitted coefficient means nothing; it is not shown and they are never chosen
    unreachable: dict[str, float] = field(default_factory=dict)
    #: base coefficients of the chosen (or, none chosen, the base) fit re-fitted to an
    #: unphysical sign, by column [SI, :data:`~diagnostics.discrepancy.balances.BASE_UNITS`]:
    #: the base model absorbs what the design cannot separate (a negative viscous friction
    #: at one load, a discrepancy pass)
    unphysical: dict[str, float] = field(default_factory=dict)
    #: variance inflation factor of each candidate's column beside the base columns on this
    #: design (:func:`~diagnostics.discrepancy.vif.candidate_vif`; ``inf`` in their span):
    #: reported, never filtered on
    vif: dict[str, float] = field(default_factory=dict)

    def candidate_dicts(self) -> dict[str, dict[str, Any]]:
        """JSON-able single-term fits by effect: coefficient and its standard error [SI of
        the entry's parameter], t, p, RMS contribution [balance unit], plausibility; for an
        unreachable candidate no numbers but why (``identifiable`` false, ``reach``); for
        every candidate its VIF (:attr:`vif`, null where infinite)."""
        out: dict[str, dict[str, Any]] = {}
        for k, t in self.singles.items():
            if k in self.unreachable:
                out[k] = {"coefficient": None, "stderr": None, "t": None, "p": None,
                          "rms_contribution": None, "plausible": None, "identifiable": False,
                          "reach": self.unreachable[k],
                          "why": "not identifiable on this design: at the top of its "
                                 "plausible range it moves the balance by at most "
                                 f"{self.unreachable[k]:.3g} {self.unit}, under a hundredth "
                                 "of the practical size"}
            else:
                out[k] = {"coefficient": t.coefficient, "stderr": t.stderr, "t": t.t, "p": t.p,
                          "rms_contribution": t.rms_contribution, "plausible": t.plausible,
                          "identifiable": True}
            out[k]["vif"] = _finite(self.vif.get(k, math.nan))
        return out

    def vif_dict(self) -> dict[str, float | None]:
        """:attr:`vif` as JSON-able data: every candidate, null where infinite."""
        return {k: _finite(v) for k, v in self.vif.items()}


def _finite(v: float) -> float | None:
    return v if math.isfinite(v) else None

