"""Do the data still hold the effects the rig carries?

A rig the workflow augmented carries each named effect with its fitted coefficient ``k``;
every balance then checks the data against the model *with* it (its term ``k·x`` moved to
the target, :func:`diagnostics.discrepancy.balances.carried`) and the effect is no longer
a candidate.  So an effect the data no longer hold — the seals were replaced after the
friction was named — went unnoticed: the moved target then holds ``−k·x``, a term no
candidate has, and a user pass got "no effect: the gap is within the noise" where the
same size of gap, of the other sign, had named the effect (t = 14.5).

Here each carried effect's column is fitted again beside the balance's base columns, as
the selection fits a candidate (:mod:`diagnostics.discrepancy.selection`: scaled columns,
Newey-West errors over :data:`~diagnostics.discrepancy.selection.HAC_LAGS` samples): the
change ``δk`` of its coefficient, and the fraction ``(k + δk)/k`` of the stored effect the
data hold, with its 95 % interval.  An effect is *not held* when ``δk`` is significant at
the selection's level and the interval of the fraction lies below :data:`HELD_BELOW`;
*exceeded* when it lies above :data:`HELD_ABOVE`.  Either way the verdict cannot be "no
effect" (:func:`diagnostics.discrepancy.workflow.discover`).  The fraction comes from the
equation error, the stored ``k`` from the output-error re-fit by re-simulation, which may
differ by some tens of per cent: the bands are wide for that reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from diagnostics.discrepancy.balances import BalanceData
from diagnostics.discrepancy.regression import hac_cov, scaled_columns
from diagnostics.discrepancy.selection import ALPHA, HAC_LAGS
from sim.components.effects import EFFECTS

__all__ = ["HELD_ABOVE", "HELD_BELOW", "CarriedCheck", "carried_statement", "check_carried"]

#: the interval of the held fraction below this: the data do not hold the effect [-]
HELD_BELOW = 0.5
#: ... above this: they hold more of it than the rig carries [-]
HELD_ABOVE = 2.0


@dataclass(frozen=True)
class CarriedCheck:
    """One carried effect checked on one balance."""

    effect: str
    balance: str
    #: the stored coefficient [SI unit of the effect's coefficient]
    stored: float
    #: its change fitted on the data, and the standard error [same unit]
    change: float
    stderr: float
    t: float
    #: the fraction of the stored effect the data hold, and its 95 % interval [-]
    held: float
    held_interval: tuple[float, float]

    @property
    def significant(self) -> bool:
        """``δk`` significant at the selection's level (:data:`~diagnostics.discrepancy.
        selection.ALPHA`, two-sided)."""
        return abs(self.t) >= float(stats.norm.ppf(1.0 - ALPHA / 2.0))

    @property
    def outcome(self) -> str:
        """``"held"``, ``"not held"`` or ``"exceeded"`` (module docstring)."""
        if self.significant and self.held_interval[1] < HELD_BELOW:
            return "not held"
        if self.significant and self.held_interval[0] > HELD_ABOVE:
            return "exceeded"
        return "held"

    def to_dict(self) -> dict[str, object]:
        """JSON-ready form (the report's ``carried`` list)."""
        return {"effect": self.effect, "balance": self.balance, "stored": self.stored,
                "change": self.change, "stderr": self.stderr, "t": self.t,
                "held": self.held, "held_interval": list(self.held_interval),
                "outcome": self.outcome}


def check_carried(data: list[BalanceData]) -> list[CarriedCheck]:
    """Every carried effect of every balance fitted again (module docstring)."""
    out: list[CarriedCheck] = []
    for d in data:
        if not d.carried or d.y.size < 3:
            continue
        for effect, (k, x) in d.carried.items():
            # the selection's scaled columns, the carried effect's last
            _, Xs, scale = scaled_columns({**d.base, effect: x})
            coef, *_ = np.linalg.lstsq(Xs, d.y, rcond=None)
            resid = d.y - Xs @ coef
            cov = hac_cov(Xs, resid, HAC_LAGS)
            j = Xs.shape[1] - 1
            change = float(coef[j] / scale[j])
            se = math.sqrt(max(float(cov[j, j]), 1e-300)) / float(scale[j])
            half = 1.96 * se / abs(k)
            held = 1.0 + change / k
            out.append(CarriedCheck(effect, d.balance.name, k, change, se, change / se, held,
                                    (held - half, held + half)))
    return out


def carried_statement(checks: list[CarriedCheck]) -> str:
    """The sentence the verdict's message gains for each carried effect the data do not
    hold or exceed ("" if none)."""
    parts = []
    for c in checks:
        if c.outcome == "held":
            continue
        e = EFFECTS[c.effect]
        decl = e.parameter(e.entry.coefficient)
        unit = f" {decl.unit}" if decl is not None and decl.unit not in ("1", "-") else ""
        lo, hi = c.held_interval
        what = ("is not in these data" if c.outcome == "not held"
                else "is in these data more strongly than the rig carries it")
        parts.append(
            f"the stored {c.effect} ({e.entry.coefficient} = {c.stored:.3g}{unit}) {what}: "
            f"the {c.balance} balance holds {c.held:.2f} [{lo:.2f}, {hi:.2f}] of it "
            f"(|t| = {abs(c.t):.3g})"
            + ("; the rig may have changed since it was stored (a repair, new seals): "
               "check these data against the rig version before it" if c.outcome == "not held"
               else "; the effect may have grown: run the workflow from the rig version "
                    "before it"))
    return "; ".join(parts)
