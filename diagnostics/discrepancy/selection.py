"""Selection of named effects in one balance (DISCREPANCY.md §4-5). Every subset of at most
two candidate columns is fitted together with the base columns (always in, unpenalised) by
least squares on unit-RMS columns. A subset is *admissible* when each added term passes a
Bonferroni-corrected two-sided t-test (α = 0.01 over the candidates of the balance) with
HAC (Newey-West) standard errors, has the expected sign, lies within 10× the top of its
plausible range, leaves the re-fitted base parameters with their physical signs (friction,
conductances, displacement ≥ 0), and its contribution is larger than the practical size
(0.1 % of the balance's full scale, RMS; for an entry whose signature is only at slow
piston speed, its peak: it acts on a few samples; in a flow balance with the samples of a
piston held at its stop, the larger of its RMS in the motion and at the stop). The
admissible subset with the lowest BIC is chosen if it improves on the base fit by at least
10 — except that once an admissible subset shows the gap is of practical size, a *single*
term that passes every check but the practical size competes too (:attr:`Fit.small`): the
practical size says whether there is a gap worth explaining, the BIC which explanation
fits it (on the hidden-effect bench a true pressure-dependent pump clearance at 4σ
explained 0.93× the practical size and its t was 29, while the compressibility loss,
t = 14, passed it at 1.09× and was named instead).
Pairs still need every term of practical size, each judged by what it adds beyond the
other columns (the RMS of the fit's loss when it is dropped): two nearly collinear columns
can cancel each other at sizes far above the practical one (stated load and seal friction
did, ±170 N of 15 N, on noise-free data and on a 4σ Couette drag).  Admissible subsets within
ΔBIC < 2 of it are competing explanations; those within ΔBIC < :data:`NEAR_BIC`, and
singles whose column nearly repeats a chosen one's (:data:`NEAR_CORR`), are *near*
alternatives, which the workflow re-fits in output-error form to tell apart
(:mod:`~diagnostics.discrepancy.workflow`). Candidates whose columns are linearly
dependent on the base columns or on each other on this test design (relative residual
norm < 1e-3 after projection) form *ambiguity groups*, reported together. A moving-block
bootstrap gives each chosen term's inclusion frequency. Each candidate's variance inflation
factor beside the base columns (:mod:`~diagnostics.discrepancy.vif`) is reported with its
minimum detectable size; nothing is filtered on it (DISCREPANCY.md, "Pitfalls").
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt
from scipy import stats

from diagnostics.discrepancy.balances import BalanceData
from diagnostics.discrepancy.regression import (
    bic,
    hac_cov,
    in_span,
    moving_blocks,
    scaled_columns,
    unique_rms,
)
from diagnostics.discrepancy.selection_result import Fit, Selection, Term
from diagnostics.discrepancy.vif import candidate_vif
from sim.components.effects import EFFECTS
from sim.errors import MeasurementError

__all__ = ["ALPHA", "BIC_MARGIN", "NEAR_BIC", "PRACTICAL", "Fit", "Selection", "Term",
           "require_samples", "select"]

Arr = npt.NDArray[np.float64]

ALPHA = 0.01
BIC_MARGIN = 10.0
#: admissible subsets within this ΔBIC of the chosen one are near alternatives
NEAR_BIC = 10.0
#: |correlation| of two candidate columns, base columns projected out, above which an
#: admissible single is a near alternative of the chosen term whatever its ΔBIC
NEAR_CORR = 0.98
#: practical size: RMS contribution ≥ this fraction of the balance's full scale
PRACTICAL = 0.001
#: a candidate whose largest plausible move of the balance, anywhere on the design, is
#: below this fraction of the practical size is not identifiable there (:func:`_reach`) [-]
UNREACHABLE = 0.01
#: Newey-West lag [samples at the analysis rate] (≥ the Savitzky-Golay window)
HAC_LAGS = 60


def _reach(data: BalanceData) -> dict[str, float]:
    """Candidates whose column, at the top of the entry's plausible range, moves the balance
    by less than :data:`UNREACHABLE` of the practical size at every sample, with that
    largest move [balance unit].

    A Stribeck column on strokes without slow motion is ~1e-40: its scaled fit reads a
    coefficient of 1e39 with a t of 5 (a discrepancy pass), which no design of these
    records can check; such a candidate is not identifiable here, as a column in the base
    columns' span is not.
    """
    out: dict[str, float] = {}
    for name, col in data.candidates.items():
        lo, hi = EFFECTS[name].entry.plausible
        most = float(np.max(np.abs(col), initial=0.0)) * max(abs(lo), abs(hi))
        if most < UNREACHABLE * PRACTICAL * data.full_scale:
            out[name] = most
    return out


#: Fewest samples per fitted term a balance must hold for the selection [-].
MIN_SAMPLES_PER_TERM = 5


def _fit(y: Arr, Xb: Arr, Xc: Arr, names: list[str], scale: Arr, data: BalanceData,
         m: int, ys: float, bnames: list[str], lags: int = HAC_LAGS) -> tuple[Fit, Arr, Arr]:
    X = np.hstack([Xb, Xc])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    resid = y - X @ coef
    rss = float(resid @ resid)
    n = y.size
    cov = hac_cov(X, resid, lags)
    nb = Xb.shape[1]
    t_crit = stats.norm.ppf(1 - ALPHA / (2 * max(m, 1)))
    terms: list[Term] = []
    reasons: list[str] = []
    small = False
    for j, name in enumerate(names):
        k = nb + j
        se = math.sqrt(max(cov[k, k], 1e-300))
        tval = coef[k] / se
        p = float(2 * stats.norm.sf(abs(tval)))
        entry = EFFECTS[name].entry
        c_si = coef[k] / scale[j]
        se_si = se / scale[j]
        if entry.window == "slow":
            # a slow-speed signature acts on a few samples: its size is its peak there
            contrib = float(np.max(np.abs(Xc[:, j] * coef[k]))) * ys
        elif data.held is not None and 0 < data.held.sum() < data.held.size:
            # judged in the motion and at the stop apart: a leak's contribution at the
            # stop must not be diluted by the motion, nor a motion signature by the hold
            contrib = max(float(np.sqrt(np.mean((Xc[part, j] * coef[k]) ** 2)))
                          for part in (data.held, ~data.held)) * ys
        else:
            contrib = float(np.sqrt(np.mean((Xc[:, j] * coef[k]) ** 2))) * ys
        if len(names) > 1:
            # in a pair, what the term adds beyond the other columns: two nearly collinear
            # columns can cancel each other at sizes far above the practical one
            contrib = min(contrib, unique_rms(X, k, coef[k]) * ys)
        lo, hi = entry.plausible
        span = hi - lo
        plausible = (lo - 10 * span) <= c_si <= (hi + 10 * span) if entry.sign == 0 else \
            0.0 <= entry.sign * c_si <= 10 * max(abs(lo), abs(hi))
        terms.append(Term(name, c_si, se_si, float(tval), p, contrib, bool(plausible)))
        if abs(tval) < t_crit:
            reasons.append(f"{name}: not significant (|t| = {abs(tval):.2g} < {t_crit:.2g})")
        if not plausible:
            reasons.append(f"{name}: coefficient {c_si:.3g} outside the sign/plausible range")
        if contrib < PRACTICAL * data.full_scale:
            small = True
            reasons.append(f"{name}: below the practical size ({contrib:.3g} < "
                           f"{PRACTICAL * data.full_scale:.3g} {data.balance.unit} RMS)")
    for j, bname in enumerate(bnames):
        sign = data.base_signs.get(bname)
        if sign is not None and sign * coef[j] < 0:
            reasons.append(f"base parameter {bname} re-fitted to an unphysical sign: the "
                           "terms trade off against the base model")
    only_small = small and all("below the practical size" in r for r in reasons)
    fit = Fit(terms, bic(rss, n, X.shape[1]), rss, not reasons, reasons, only_small)
    return fit, np.asarray(coef, dtype=float), resid


def _twins(Xb: Arr, Xc: Arr, cnames: list[str], chosen: tuple[str, ...]) -> set[str]:
    """Candidates whose column, with the base columns projected out, correlates with a
    chosen term's at |r| ≥ :data:`NEAR_CORR` (on this test design)."""
    coef, *_ = np.linalg.lstsq(Xb, Xc, rcond=None)
    R = Xc - Xb @ coef
    norms = np.linalg.norm(R, axis=0)
    norms[norms == 0] = 1.0
    R = R / norms
    out: set[str] = set()
    for c in chosen:
        r = R.T @ R[:, cnames.index(c)]
        out |= {n for n, v in zip(cnames, r, strict=True) if n != c and abs(v) >= NEAR_CORR}
    return out


def require_samples(data: BalanceData) -> None:
    """Raise :class:`MeasurementError` when the balance has too few usable samples to fit
    its base terms and two candidates (:data:`MIN_SAMPLES_PER_TERM` each)."""
    n, n_base = data.y.size, len(data.base)
    if n < MIN_SAMPLES_PER_TERM * (n_base + 2):
        raise MeasurementError(
            f"the {data.balance.name} balance has {n} usable samples; at least "
            f"{MIN_SAMPLES_PER_TERM * (n_base + 2)} are needed to fit its "
            f"{n_base} base terms and two candidates (longer records, or a higher "
            "sample rate)", field="file")


def select(data: BalanceData, *, bootstrap: int = 30, seed: int = 0, lags: int = HAC_LAGS,
           block: int = 500) -> Selection:
    """Select the effect(s) of one balance (module docstring).

    Parameters
    ----------
    data
        The balance evaluated on the data.
    bootstrap, seed
        Bootstrap replicates for the inclusion frequencies and their seed.
    lags
        Newey-West lag [samples]; 0 gives White's heteroscedasticity-robust errors
        (independent rows: steady test points).
    block
        Moving-block length of the bootstrap [samples]; 1 for independent rows.
    """
    require_samples(data)
    y_si = data.y
    n = y_si.size
    ys = float(np.sqrt(np.mean(y_si * y_si))) or 1.0
    y = y_si / ys
    bnames, Xb, bscale = scaled_columns(data.base)
    cnames, Xc_all, cscale = scaled_columns(data.candidates)
    m = len(cnames)
    base_coef, *_ = np.linalg.lstsq(Xb, y, rcond=None)
    base_resid = y - Xb @ base_coef
    base_bic = bic(float(base_resid @ base_resid), n, Xb.shape[1])
    # ambiguity groups on this design
    dep_base = [c for j, c in enumerate(cnames) if in_span(Xb, Xc_all[:, j])]
    groups: list[list[str]] = [["base", c] for c in dep_base]
    free = [c for c in cnames if c not in dep_base]
    for a, b in itertools.combinations(free, 2):
        ja, jb = cnames.index(a), cnames.index(b)
        if in_span(np.hstack([Xb, Xc_all[:, [ja]]]), Xc_all[:, jb]):
            groups.append([a, b])
    fits: dict[tuple[str, ...], Fit] = {}
    singles: dict[str, Term] = {}
    detectable: dict[str, float] = {}
    t_crit = stats.norm.ppf(1 - ALPHA / (2 * max(m, 1)))
    for size in (1, 2):
        for subset in itertools.combinations(free, size):
            if size == 2 and [subset[0], subset[1]] in groups:
                continue
            idx = [cnames.index(c) for c in subset]
            fit, _, _ = _fit(y, Xb, Xc_all[:, idx], list(subset), cscale[idx] / ys, data, m,
                             ys, bnames, lags)
            fits[subset] = fit
            if size == 1:
                singles[subset[0]] = fit.terms[0]
                # smallest RMS contribution detected at 80 % power
                se_scaled = fit.terms[0].stderr * cscale[idx[0]] / ys
                detectable[subset[0]] = float(max(
                    (t_crit + stats.norm.ppf(0.8)) * se_scaled * ys,
                    PRACTICAL * data.full_scale))
    unreachable = _reach(data)
    for c in [*dep_base, *unreachable]:
        detectable[c] = math.inf
    # a subset with a candidate the design cannot identify is never chosen
    fits = {k: f for k, f in fits.items() if not unreachable.keys() & set(k)}
    admissible = {k: f for k, f in fits.items() if f.admissible and base_bic - f.bic >= BIC_MARGIN}
    if admissible:
        # a gap of practical size: a single below it that fits better competes (docstring)
        admissible |= {k: f for k, f in fits.items()
                       if len(k) == 1 and f.small and base_bic - f.bic >= BIC_MARGIN}
    chosen_key: tuple[str, ...] | None = None
    competing: list[list[str]] = []
    near: list[Fit] = []
    if admissible:
        chosen_key = min(admissible, key=lambda k: admissible[k].bic)
        best = admissible[chosen_key].bic
        ranked = sorted(admissible.items(), key=lambda kv: kv[1].bic)
        competing = [list(k) for k, f in ranked if k != chosen_key and f.bic - best < 2.0]
        twins = _twins(Xb, Xc_all, cnames, chosen_key)
        near = [f for k, f in ranked if k != chosen_key
                and (f.bic - best < NEAR_BIC or (len(k) == 1 and k[0] in twins))]
    chosen = fits[chosen_key] if chosen_key is not None else None
    small = sorted((f for k, f in fits.items()
                    if len(k) == 1 and f.small and base_bic - f.bic >= BIC_MARGIN),
                   key=lambda f: f.bic)
    inclusion: dict[str, float] = {}
    resid_si = base_resid * ys
    base_named = {bn: float(c * ys / s) for bn, c, s in zip(bnames, base_coef, bscale, strict=True)}
    if chosen_key is not None:
        idx = [cnames.index(c) for c in chosen_key]
        X = np.hstack([Xb, Xc_all[:, idx]])
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        resid_si = (y - X @ coef) * ys
        base_named = {bn: float(c * ys / s) for bn, c, s in
                      zip(bnames, coef[: len(bnames)], bscale, strict=True)}
        inclusion = _bootstrap(y, Xb, Xc_all, cnames, [c for c in free if c not in unreachable],
                               groups, chosen_key, bootstrap, seed, block)
    unphysical = {bn: c for bn, c in base_named.items() if data.base_signs.get(bn, 0.0) * c < 0}
    return Selection(data.balance.name, data.balance.unit, chosen, base_bic,
                     base_bic - chosen.bic if chosen else 0.0, competing, groups, inclusion,
                     detectable, singles, base_named, resid_si, base_resid * ys,
                     data.full_scale, near, small, data.noise_floor, unreachable, unphysical,
                     candidate_vif(data.base, data.candidates))


def _bootstrap(y: Arr, Xb: Arr, Xc: Arr, cnames: list[str], free: list[str],
               groups: list[list[str]], chosen: tuple[str, ...], reps: int, seed: int,
               block: int = 500) -> dict[str, float]:
    """Inclusion frequency of each chosen term under a moving-block bootstrap (BIC choice).

    Each replicate projects the base columns out once (QR; Frisch-Waugh-Lovell: the
    residual of base + subset equals the residual of the projected target on the projected
    subset columns), so a subset costs a fit of one or two columns.
    """
    rng = np.random.default_rng(seed)
    n = y.size
    counts = dict.fromkeys(chosen, 0)
    subsets = [tuple(s) for size in (1, 2) for s in itertools.combinations(free, size)
               if not (size == 2 and list(s) in groups)]
    index = {s: [cnames.index(c) for c in s] for s in subsets}
    kb = Xb.shape[1]
    for _ in range(reps):
        rows = moving_blocks(n, block, rng)
        yb, Xbb, Xcb = y[rows], Xb[rows], Xc[rows]
        q, r_ = np.linalg.qr(Xbb)
        d = np.abs(np.diag(r_))
        if d.size and float(d.min()) > 1e-10 * float(d.max()):
            ry = yb - q @ (q.T @ yb)
            rc = Xcb - q @ (q.T @ Xcb)
        else:  # rank-deficient base on this replicate: project with a least-squares fit
            ry = yb - Xbb @ np.linalg.lstsq(Xbb, yb, rcond=None)[0]
            rc = Xcb - Xbb @ np.linalg.lstsq(Xbb, Xcb, rcond=None)[0]
        best_key: tuple[str, ...] = ()
        best = bic(float(ry @ ry), n, kb) - BIC_MARGIN
        for s in subsets:
            a = rc[:, index[s]]
            c, *_ = np.linalg.lstsq(a, ry, rcond=None)
            r = ry - a @ c
            b = bic(float(r @ r), n, kb + len(s))
            if b < best:
                best, best_key = b, s
        for name in chosen:
            counts[name] += name in best_key
    return {k: v / max(reps, 1) for k, v in counts.items()}
