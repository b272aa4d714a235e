"""Output-error confirmation of what the balances propose (step 4 of the workflow).

:func:`confirm_chosen` takes each balance's chosen explanation (and its near alternatives,
told apart by re-simulation) and keeps it when its re-fitted coefficient is significant
and the held-out excess gap shrinks by the confirmation ratio.

:func:`confirm_small` is the second look when that names nothing and the held-out gap is
still above the noise: the singles a balance found significant, of physical sign, with the
BIC margin, and refused *only* because their equation-error contribution is below the
practical size (:data:`~diagnostics.discrepancy.selection.PRACTICAL`, 0.1 % of the
balance's full scale: the guard against differentiation and integration error in
dynamic data, DISCREPANCY.md).  The practical size is a fraction of full scale, not of the
instruments' noise: on the hidden-effect bench a pressure-dependent seal friction, a
Couette drag or a viscosity-law error at 4 σ reaches |t| = 17-68 in its balance with an
RMS of 0.6-0.7 of the practical size, while the held-out outputs are 3-29 σ off.  Such a
single is re-fitted by re-simulation and named only if, besides the two tests of every
proposal (output-error coefficient significant, held-out excess gap shrinking by the
confirmation ratio), it closes the held-out steady gap to the noise (no channel above
:data:`~diagnostics.discrepancy.verdict.OUTPUT_GAP` σ, the test of the build-up screen,
:mod:`~diagnostics.discrepancy.transient`) or shrinks the held-out excess by
:data:`SMALL_RATIO` times the confirmation ratio: below the practical size the equation
error alone is not evidence enough, the outputs must say it plainly.  The second way is
for an effect the training records barely constrain: a viscosity-law error at 4 σ, the
training records at 40-50 °C, re-fits 4 % off the truth (its output-error cost moves by
1 in 18,000 over ±4 %), and the held-out slow stroke at 50 °C, 29 σ off before, is left
at 4.6-6.9 σ in two channels: an excess ratio of about 6.  On the bench's drifted and
out-of-library cases no single below the practical size passed the equation-error tests
at all (12 drifted, 8 out of library, seeds 0-3), so this path did not run there.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from diagnostics.discrepancy.gap import GapRow, gap_table
from diagnostics.discrepancy.refit import compare_from, tell_apart, with_effects
from diagnostics.discrepancy.refit import refit as output_error_refit
from diagnostics.discrepancy.selection import PRACTICAL, Fit, Selection
from diagnostics.discrepancy.simulate import simulate_record
from diagnostics.discrepancy.slow import is_slow, slow_confirmed, slow_records, slow_refit
from diagnostics.discrepancy.transient import above_noise, is_significant
from diagnostics.discrepancy.verdict import (
    HELD_OUT_MIN_EXCESS,
    STEADY_SLACK,
    excess,
    excess_ratio,
)
from diagnostics.timeseries import SeriesRecord
from sim.components.effects import EFFECTS
from sim.errors import InputError, SimulationError
from sim.rigs.assembly import Rig
from sim.rigs.schema import validate_rig_document

__all__ = ["Confirmed", "Small", "confirm_chosen", "confirm_small", "nested_pick", "start_of",
           "with_pair"]

Progress = Callable[[float, str], None]

#: below the practical size, a held-out excess ratio this many times the confirmation
#: ratio stands in for closing the held-out gap to the noise [-]
SMALL_RATIO = 2.0


def start_of(fit: Fit) -> dict[str, float]:
    """Output-error start of a fitted subset: ``effect.param`` → equation-error value."""
    return {f"{t.effect}.{EFFECTS[t.effect].entry.coefficient}": t.coefficient
            for t in fit.terms}


@dataclass
class Confirmed:
    """What :func:`confirm_chosen` kept: coefficient values and 1-σ errors by
    ``effect.param`` [unit of the parameter], the effects not confirmed, those whose
    re-fitted rig could not be simulated (with the solver's reason), the alternative each
    balance picked by re-simulation, the balances whose alternatives stayed alike, and the
    effects kept where the held-out records showed no gap to shrink (below
    :data:`~diagnostics.discrepancy.verdict.HELD_OUT_MIN_EXCESS`: kept on the in-sample
    tests alone)."""

    values: dict[str, float] = field(default_factory=dict)
    errors: dict[str, float] = field(default_factory=dict)
    rejected: list[str] = field(default_factory=list)
    unsimulable: list[str] = field(default_factory=list)
    picked: dict[str, Fit] = field(default_factory=dict)
    apart: dict[str, list[str]] = field(default_factory=dict)
    untested: list[str] = field(default_factory=list)


def _held_gap(doc: Mapping[str, Any], values: Mapping[str, float],
              held: Sequence[SeriesRecord], channels: Sequence[str]) -> list[GapRow]:
    trial = Rig.from_spec(validate_rig_document(with_effects(dict(doc), values)))
    return [row for r in held for row in gap_table(r, simulate_record(trial, r), channels)]


def with_pair(options: Sequence[Fit]) -> list[Fit]:
    """``options`` (the chosen fit and its near alternatives) and, when two of them are
    singles, those two together, if not there already: re-simulation tells apart what
    the equation error could not, and the truth may be both.  A hidden seal friction with
    a stated load 3 % low was named ``load_scale`` alone at k_F 0.0386 and stored (a
    simulation engineer's pass): the two columns nearly repeat each other once the base
    friction is re-fitted, so the equation error's pair split them wildly (seal friction
    at 10× its value) and failed the practical size, while re-simulated the pair gives back
    both (k_p 1.52e-5 m², k_F 0.0298) and beats the single by ΔBIC ≈ 180."""
    out = list(options)
    singles = [f for f in out if len(f.terms) == 1]
    if len(singles) < 2:
        return out
    a, b = singles[0].terms[0], singles[1].terms[0]
    if any({t.effect for t in f.terms} == {a.effect, b.effect} for f in out):
        return out
    out.append(Fit([a, b], math.nan, math.nan, False,
                   ["the two nearest singles together, told apart by re-simulation"]))
    return out


def nested_pick(best: int, group: Sequence[int], starts: Sequence[Mapping[str, float]]
                ) -> tuple[int, list[int]]:
    """The option taken among re-fitted fits that the data cannot separate, and its rivals.

    Nested fits alike (``group``, within :data:`~diagnostics.discrepancy.refit.APART` of
    the ``best``, by rising BIC): the extra term is not needed, so the smaller fit of the
    lowest BIC is taken (before, the first by the equation error's order), and a larger
    fit that contains it is no rival of it.

    Parameters
    ----------
    best, group
        As :func:`~diagnostics.discrepancy.refit.tell_apart` returns them.
    starts
        Each option's ``effect.param`` keys (its terms).
    """
    smaller = [i for i in group if set(starts[i]) < set(starts[best])]
    pick = smaller[0] if smaller else best
    return pick, [i for i in group if i == pick or not set(starts[pick]) < set(starts[i])]


def _of_practical_size(s: Selection) -> Callable[[Mapping[str, float]], bool]:
    """Whether each term of a re-simulated fit of several terms is of practical size in
    the balance of ``s`` — its re-fitted coefficient times its column's RMS (the
    equation-error single's contribution over its coefficient) at least
    :data:`~diagnostics.discrepancy.selection.PRACTICAL` of the full scale.  A pure seal
    friction at 16 σ was named with a stated-load error of k_F 0.00074 beside it (≈ 3 N
    RMS of 15 N; the pair's cost 21 below the single's over 18,000 samples, what the
    solver's own error, ≤ 0.1 σ, can leave): a term that small is not a second effect."""
    def ok(values: Mapping[str, float]) -> bool:
        if len(values) < 2:
            return True
        for key, value in values.items():
            term = s.singles.get(key.partition(".")[0])
            if term is None or term.coefficient == 0.0:
                continue
            size = abs(value) * term.rms_contribution / abs(term.coefficient)
            if size < PRACTICAL * s.full_scale:
                return False
        return True
    return ok


def confirm_chosen(doc: dict[str, Any], rig: Rig, selections: Sequence[Selection],
                   train: Sequence[SeriesRecord], held: Sequence[SeriesRecord],
                   channels: Sequence[str], sig: Mapping[str, float],
                   gap_before: Sequence[GapRow], *, refit: bool, max_nfev: int,
                   confirm_ratio: float, report: Progress) -> Confirmed:
    """Confirm each balance's chosen explanation on its own, in output-error form (module
    docstring); near alternatives of the equation error are re-fitted and told apart."""
    out = Confirmed()
    chosen = [s for s in selections if s.chosen is not None]
    for k, s in enumerate(chosen):
        assert s.chosen is not None
        options = with_pair([s.chosen, *s.near]) if refit else [s.chosen]
        starts = [start_of(f) for f in options]
        report(0.35 + 0.4 * k / len(chosen), f"output-error re-fit of {', '.join(starts[0])}")
        # a slow-speed effect (stick-slip) is re-fitted and confirmed on statistics of
        # the timed slow strokes; without slow strokes it cannot be confirmed
        fit = s.chosen
        try:
            slow = refit and is_slow(list(starts[0]))
            if slow:
                start = starts[0]
                fitted, fit_err = slow_refit(doc, start, slow_records(train, rig), channels, sig)
            elif len(options) > 1:
                best, group, fits = tell_apart(doc, starts, train, channels, sig, max_nfev,
                                               admissible=_of_practical_size(s))
                best, group = nested_pick(best, group, starts)
                (fitted, fit_err), start = fits[best], starts[best]
                out.picked[s.balance] = options[best]
                if len(group) > 1:
                    out.apart[s.balance] = sorted({t.effect for i in group
                                                   for t in options[i].terms})
            elif refit:
                start = starts[0]
                fitted, fit_err = output_error_refit(doc, start, train, channels, sig, max_nfev)
            else:
                start = starts[0]
                fitted, fit_err = dict(start), {key: float("nan") for key in start}
            fit = out.picked.get(s.balance, s.chosen)
            # without a re-fit the equation error's significance stands (errors NaN by
            # design); after one, an error the fit could not estimate is not significant
            significant = not refit or all(is_significant(fitted[key], fit_err[key])
                                           for key in fitted)
            if slow:
                trial = Rig.from_spec(validate_rig_document(with_effects(doc, fitted)))
                confirmed = slow_confirmed(rig, trial, slow_records(held, rig), channels, sig,
                                           confirm_ratio)
            else:
                # an effect acting in the build-up after a switch is judged there too, and
                # must neither cost the steady motion nor leave every steady channel that
                # was above the noise there: hidden entrained air (α 0.005) re-fitted 23 %
                # low shrank the build-up gap enough to pass while every channel's steady
                # gap grew (Q_meter_C 3.2 σ → 4.2 σ), and on another seed re-fitted 18×
                # low left it at 3.2 σ; both were named and stored.  Not confirmed here,
                # the screen of the build-up effects re-fits it from its own scan.
                regions = ("steady",) if compare_from(list(start)) > 0 else ("steady", "after step")
                gap_after = _held_gap(doc, fitted, held, channels)
                confirmed = excess_ratio(gap_before, gap_after, sig, regions) >= confirm_ratio
                if confirmed and "after step" in regions:
                    off_before = set(above_noise(gap_before, sig))
                    off_after = set(above_noise(gap_after, sig))
                    confirmed = (excess(gap_after, sig) <= excess(gap_before, sig) + STEADY_SLACK
                                 and (not off_before or off_after < off_before))
        except (SimulationError, InputError) as exc:
            # a candidate whose re-fit (or its augmented rig) cannot be simulated is not
            # confirmed: it is rejected with the solver's reason and the others go on
            out.unsimulable += [f"{t.effect} ({exc})" for t in fit.terms]
            continue
        if significant and confirmed:
            out.values.update(fitted)
            out.errors.update(fit_err)
            if not slow and excess(gap_before, sig, regions) < HELD_OUT_MIN_EXCESS:
                # the ratio of two gaps at the noise says nothing (1.05 σ → 0.99 σ gave an
                # infinite ratio: a design pass); the verdict says what decided
                out.untested += [t.effect for t in fit.terms]
        else:
            out.rejected += [t.effect for t in fit.terms]
    return out


@dataclass
class Small:
    """A single below the practical size that :func:`confirm_small` kept: its balance and
    equation-error fit, the coefficient key (``effect.param``), the output-error value and
    1-σ error [unit of the parameter], the held-out excess-gap ratio [-] and the channels
    still above the noise on the held-out records."""

    selection: Selection
    fit: Fit
    key: str
    value: float
    error: float
    ratio: float
    left: list[str]


def confirm_small(doc: dict[str, Any], selections: Sequence[Selection],
                  train: Sequence[SeriesRecord], held: Sequence[SeriesRecord],
                  channels: Sequence[str], sig: Mapping[str, float],
                  gap_before: Sequence[GapRow], *, max_nfev: int, confirm_ratio: float
                  ) -> tuple[Small | None, list[str]]:
    """Re-fit each balance's best single below the practical size (module docstring); the
    one with the largest held-out ratio among those that pass, or None, and the reasons of
    those that did not."""
    kept: list[Small] = []
    notes: list[str] = []
    for s in selections:
        if not s.small or is_slow(list(start_of(s.small[0]))):
            continue
        fit = s.small[0]
        (term,) = fit.terms
        start = start_of(fit)
        (key,) = start
        size = (f"{term.rms_contribution:.3g} < {PRACTICAL * s.full_scale:.3g} {s.unit} RMS "
                f"in the {s.balance} balance")
        try:
            values, errors = output_error_refit(doc, start, train, channels, sig, max_nfev)
            after = _held_gap(doc, values, held, channels)
        except (SimulationError, InputError) as exc:
            notes.append(f"{term.effect} ({size}; the re-fitted rig could not be simulated: "
                         f"{exc})")
            continue
        value, err = values[key], errors[key]
        regions = ("steady",) if compare_from([key]) > 0 else ("steady", "after step")
        ratio = excess_ratio(gap_before, after, sig, regions)
        if not is_significant(value, err):
            notes.append(f"{term.effect} ({size}; output-error coefficient not significant)")
        elif ratio < confirm_ratio:
            notes.append(f"{term.effect} ({size}; held-out gap ratio {ratio:.2f} < "
                         f"{confirm_ratio})")
        elif (left := above_noise(after, sig)) and ratio < SMALL_RATIO * confirm_ratio:
            notes.append(f"{term.effect} ({size}; held-out gap ratio {ratio:.2f} < "
                         f"{SMALL_RATIO * confirm_ratio:.3g} and the gap left above the noise: "
                         f"{', '.join(left)})")
        else:
            kept.append(Small(s, fit, key, value, err, ratio, left))
    return (max(kept, key=lambda k: k.ratio) if kept else None), notes
