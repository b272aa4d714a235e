"""Scores of a per-cycle estimate against an ordered condition label (for reporting only).

The labels of a measured campaign enter here and nowhere else: every estimate of
:mod:`diagnostics.real` is computed without them, and this module says how well it orders
the label's classes and how much it moves with the *other* labels.

* Spearman ρ with the label and its tie ceiling (:func:`~diagnostics.real.leakage.spearman_ceiling`):
  a label with few classes has ties, so no tie-free estimate reaches 1;
* AUROC of every pair of neighbouring classes, ``P(est_b > est_a)`` for classes
  ``a < b`` of the label (``decreasing=True`` where the estimate grows as the label falls);
* within every class of the label, Spearman ρ with each other label (a confound: the
  estimate should not follow a label it does not describe).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.stats import mannwhitneyu, spearmanr

from diagnostics.real.leakage import spearman_ceiling
from sim.errors import InputError

__all__ = ["ClassScore", "auroc", "score_classes"]

Arr = npt.NDArray[np.float64]


def auroc(est: npt.ArrayLike, labels: npt.ArrayLike, a: float, b: float) -> float:
    """``P(est of class b > est of class a)`` [-] (ties count one half); NaN if a class is empty."""
    x, y = np.asarray(est, dtype=np.float64), np.asarray(labels, dtype=np.float64)
    xa, xb = x[y == a], x[y == b]
    if xa.size == 0 or xb.size == 0:
        return math.nan
    return float(mannwhitneyu(xb, xa).statistic / (xa.size * xb.size))


def _rho(x: Arr, y: Arr) -> float:
    if x.size < 3 or np.ptp(y) == 0 or np.ptp(x) == 0:
        return math.nan
    return float(spearmanr(x, y)[0])


@dataclass(frozen=True, slots=True)
class ClassScore:
    """How an estimate orders the classes of one label.

    Attributes
    ----------
    n
        Cycles scored (those with a finite estimate) [-].
    spearman, ceiling, fraction
        Spearman ρ with the label, its tie ceiling, and their ratio [-].
    auroc
        ``"a<b"`` → AUROC of the neighbouring classes a and b [-].
    within
        Other label's name → Spearman ρ with it inside each class of the scored label
        (classes where it varies) [-].
    """

    n: int
    spearman: float
    ceiling: float
    fraction: float
    auroc: dict[str, float]
    within: dict[str, tuple[float, ...]]

    @property
    def worst_auroc(self) -> float:
        """Smallest neighbouring-class AUROC [-]."""
        return float(min(self.auroc.values()))

    @property
    def worst_confound(self) -> float:
        """Largest |ρ| with another label inside a class [-] (0 when none varies)."""
        vals = [abs(v) for t in self.within.values() for v in t]
        return float(max(vals, default=0.0))

    def as_dict(self) -> dict[str, object]:
        """Plain JSON-ready form."""
        return {"n": self.n, "spearman": self.spearman, "ceiling": self.ceiling,
                "fraction_of_ceiling": self.fraction, "auroc": dict(self.auroc),
                "within": {k: list(v) for k, v in self.within.items()},
                "worst_auroc": self.worst_auroc, "worst_confound": self.worst_confound}


def score_classes(estimate: npt.ArrayLike, label: npt.ArrayLike,
                  others: Mapping[str, npt.ArrayLike], *, decreasing: bool = False) -> ClassScore:
    """Score ``estimate`` against ``label`` (module docstring); non-finite estimates are left out.

    With ``decreasing`` the estimate is expected to grow as the label *falls* (a valve
    condition of 73 % lags more than one of 100 %): ρ is taken with ``−label`` and the
    AUROC keys read ``"100>90"``.

    Raises
    ------
    InputError
        Lengths differ, or fewer than 3 finite estimates (``field="estimate"``).
    """
    est = np.asarray(estimate, dtype=np.float64)
    lab = np.asarray(label, dtype=np.float64)
    oth = {k: np.asarray(v, dtype=np.float64) for k, v in others.items()}
    if lab.shape != est.shape or any(v.shape != est.shape for v in oth.values()):
        raise InputError("estimate and labels differ in length", field="estimate")
    ok = np.isfinite(est)
    if int(ok.sum()) < 3:
        raise InputError("fewer than 3 finite estimates to score", field="estimate")
    est, lab = est[ok], (-lab[ok] if decreasing else lab[ok])
    oth = {k: v[ok] for k, v in oth.items()}
    rho = _rho(est, lab)
    ceil = spearman_ceiling(lab)
    classes = np.unique(lab)
    pairs = {(f"{-a:g}>{-b:g}" if decreasing else f"{a:g}<{b:g}"):
             auroc(est, lab, float(a), float(b))
             for a, b in itertools.pairwise(classes)}
    within = {}
    for name, v in oth.items():
        vals = (_rho(est[lab == c], v[lab == c]) for c in classes)
        within[name] = tuple(x for x in vals if not math.isnan(x))
    return ClassScore(int(est.size), rho, ceil, rho / ceil, pairs, within)
