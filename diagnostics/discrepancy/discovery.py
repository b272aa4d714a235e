"""What the discrepancy workflow returns (:func:`~diagnostics.discrepancy.workflow.discover`,
:func:`~diagnostics.discrepancy.steady.discover_steady`): the effects it named and added to
the rig, and the report with the JSON form the service answers with."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from diagnostics.discrepancy.carried_check import CarriedCheck
from diagnostics.discrepancy.drift import Drift
from diagnostics.discrepancy.gap import GapRow
from diagnostics.discrepancy.noise import Noise
from diagnostics.discrepancy.selection import PRACTICAL, Selection

__all__ = ["Discovery", "NamedEffect"]


@dataclass
class NamedEffect:
    """An effect the workflow named and added to the rig."""

    name: str
    balance: str
    explanation: str
    reference: str
    signature: str
    parameter: str
    unit: str
    equation_error: float
    value: float
    interval: tuple[float, float]
    plausible: bool
    plausible_range: tuple[float, float]
    t: float
    inclusion: float
    competing: list[list[str]]
    ambiguity: list[list[str]]


@dataclass
class Discovery:
    """Outcome of :func:`~diagnostics.discrepancy.workflow.discover` (``to_dict`` gives the JSON report).

    ``lack_of_fit`` holds the lack-of-fit F-test (:mod:`~diagnostics.discrepancy.lof`)
    ``before``/``after`` adding the named effects when the data repeat a condition
    (F, p, degrees of freedom, RMS of the misfit and pure-error σ), else it is empty.
    """

    verdict: str
    message: str
    named: list[NamedEffect]
    selections: list[Selection]
    training: list[str]
    held_out: list[str]
    gap_before: list[GapRow]
    gap_after: list[GapRow]
    whiteness_before: dict[str, float]
    whiteness_after: dict[str, float]
    rig_document: dict[str, Any]
    solver: str
    detectable: dict[str, dict[str, float]] = field(default_factory=dict)
    traces: dict[str, Any] = field(default_factory=dict, repr=False)
    lack_of_fit: dict[str, Any] = field(default_factory=dict)
    #: the base re-fit of step 6 where it ran (accepted or not), else None
    base_drift: Drift | None = None
    #: each effect the rig carries, fitted again on the data (:mod:`~diagnostics.
    #: discrepancy.carried_check`)
    carried: list[CarriedCheck] = field(default_factory=list)
    #: each output channel's noise as the records show it (:mod:`~diagnostics.discrepancy.
    #: noise`), against which the gaps are judged
    noise: dict[str, Noise] = field(default_factory=dict)
    #: per balance, the explanation re-simulation kept where it told the equation error's
    #: near alternatives apart (:func:`~diagnostics.discrepancy.refit.tell_apart`)
    picked: dict[str, list[str]] = field(default_factory=dict)
    #: what its random draws took: ``seed`` of the generator, ``bootstrap`` replicates of
    #: the inclusion frequencies, ``permutations`` of the lack-of-fit p-value where it ran
    #: (steady tables); the same data and these give the same report
    randomness: dict[str, int] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The report as JSON-able data (units in the keys' descriptions)."""
        def sel_dict(s: Selection) -> dict[str, Any]:
            return {
                "balance": s.balance, "unit": s.unit,
                "chosen": [t.effect for t in s.chosen.terms] if s.chosen else [],
                # what re-simulation kept among the near alternatives: the equation error's
                # choice and the named effect disagreed without a word (a stated-load pass)
                "picked_by_resimulation": self.picked.get(
                    s.balance, [t.effect for t in s.chosen.terms] if s.chosen else []),
                "bic_gain": s.bic_gain, "competing": s.competing, "ambiguity": s.ambiguity,
                "inclusion": s.inclusion,
                "base_coefficients": s.base_coefficients,
                "residual_rms": float(np.sqrt(np.mean(s.base_residual ** 2))),
                "practical_size": PRACTICAL * s.full_scale,
                "candidates": s.candidate_dicts(),
                "unphysical_base": s.unphysical,
                "minimum_detectable_rms": {k: (v if math.isfinite(v) else None)
                                           for k, v in s.detectable.items()},
                # each candidate's variance inflation factor beside the base columns
                # (reported, not filtered on: DISCREPANCY.md "Pitfalls"); null = infinite
                "vif": s.vif_dict(),
                "rejections": s.chosen.reasons if s.chosen else [],
            }

        def gap(rows: list[GapRow]) -> list[dict[str, Any]]:
            return [{"channel": r.channel, "unit": r.unit, "region": r.region, "rmse": r.rmse,
                     "max_abs": r.max_abs, "timing_floor": r.timing_floor} for r in rows]

        return {
            "verdict": self.verdict, "message": self.message,
            # a value the screen does not define (equation-error estimate, t) is null
            "named": [{k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                       for k, v in vars(n).items()}
                      | {"interval": list(n.interval), "plausible_range": list(n.plausible_range)}
                      for n in self.named],
            "balances": [sel_dict(s) for s in self.selections],
            "training_records": self.training, "held_out_records": self.held_out,
            "gap_before": gap(self.gap_before), "gap_after": gap(self.gap_after),
            "whiteness_before": self.whiteness_before, "whiteness_after": self.whiteness_after,
            "rig_document": self.rig_document, "solver": self.solver,
            "lack_of_fit": self.lack_of_fit,
            # the seed and the number of draws of the bootstrap (and permutation test):
            # the inclusion frequencies depend on them (a determinism pass)
            "randomness": self.randomness,
            "base_drift": self.base_drift.to_dict() if self.base_drift is not None else None,
            "carried": [c.to_dict() for c in self.carried],
            # σ [SI unit of the channel], AR(1) φ per sample [-], the sample-to-sample σ
            "noise": {c: {"sigma": n.sigma, "ar1_phi": n.phi, "sample_to_sample_sigma": n.white,
                          "coloured": n.coloured} for c, n in self.noise.items()},
        }
