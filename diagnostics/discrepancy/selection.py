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
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import stats

from diagnostics.discrepancy.balances import BalanceData
from diagnostics.discrepancy.vif import candidate_vif
from sim.components.effects import EFFECTS
from sim.errors import MeasurementError

__all__ = ["ALPHA", "BIC_MARGIN", "NEAR_BIC", "PRACTICAL", "Fit", "Selection", "Term", "hac_cov",
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
DEPENDENT = 1e-3


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


def _scaled(cols: dict[str, Arr]) -> tuple[list[str], Arr, Arr]:
    names = list(cols)
    if not names:
        return [], np.zeros((0, 0)), np.zeros(0)
    X = np.column_stack([cols[n] for n in names])
    scale = np.sqrt(np.mean(X * X, axis=0))
    scale[scale == 0] = 1.0
    return names, X / scale, scale


def hac_cov(X: Arr, resid: Arr, lags: int) -> Arr:
    """Newey-West covariance of OLS coefficients (Bartlett kernel); ``lags`` = 0 gives
    White's (HC0)."""
    n = X.shape[0]
    xtx_inv = np.linalg.pinv(X.T @ X)
    u = X * resid[:, None]
    S = u.T @ u
    for lag in range(1, min(lags, n - 1) + 1):
        w = 1.0 - lag / (lags + 1.0)
        G = u[lag:].T @ u[:-lag]
        S += w * (G + G.T)
    return np.asarray(xtx_inv @ S @ xtx_inv, dtype=float)


#: Fewest samples per fitted term a balance must hold for the selection [-].
MIN_SAMPLES_PER_TERM = 5


def _bic(rss: float, n: int, k: int) -> float:
    return n * math.log(max(rss, 1e-300) / n) + k * math.log(n)


def _dependent(B: Arr, c: Arr) -> bool:
    """Whether column ``c`` lies (to :data:`DEPENDENT`) in the span of ``B``'s columns."""
    if B.shape[1] == 0:
        return bool(np.linalg.norm(c) == 0)
    coef, *_ = np.linalg.lstsq(B, c, rcond=None)
    return bool(np.linalg.norm(c - B @ coef) < DEPENDENT * np.linalg.norm(c))


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
            contrib = min(contrib, _unique_rms(X, k, coef[k]) * ys)
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
    fit = Fit(terms, _bic(rss, n, X.shape[1]), rss, not reasons, reasons, only_small)
    return fit, np.asarray(coef, dtype=float), resid


def _unique_rms(X: Arr, k: int, coef: float) -> float:
    """RMS of what column ``k`` of ``X`` adds to the fit beyond the other columns,
    ``|coef|·‖M x_k‖/√n`` with ``M`` the projection off them (the RMS of the RSS increase
    when the term is dropped and the rest re-fitted) [units of ``X @ coef``]."""
    others = np.delete(X, k, axis=1)
    proj, *_ = np.linalg.lstsq(others, X[:, k], rcond=None)
    rest = X[:, k] - others @ proj
    return abs(coef) * float(np.sqrt(np.mean(rest * rest)))


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


def _blocks(n: int, size: int, rng: np.random.Generator) -> npt.NDArray[np.int64]:
    starts = rng.integers(0, max(n - size, 1), size=math.ceil(n / size))
    return np.concatenate([np.arange(s, min(s + size, n)) for s in starts])[:n]


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
    bnames, Xb, bscale = _scaled(data.base)
    cnames, Xc_all, cscale = _scaled(data.candidates)
    m = len(cnames)
    base_coef, *_ = np.linalg.lstsq(Xb, y, rcond=None)
    base_resid = y - Xb @ base_coef
    base_bic = _bic(float(base_resid @ base_resid), n, Xb.shape[1])
    # ambiguity groups on this design
    dep_base = [c for j, c in enumerate(cnames) if _dependent(Xb, Xc_all[:, j])]
    groups: list[list[str]] = [["base", c] for c in dep_base]
    free = [c for c in cnames if c not in dep_base]
    for a, b in itertools.combinations(free, 2):
        ja, jb = cnames.index(a), cnames.index(b)
        if _dependent(np.hstack([Xb, Xc_all[:, [ja]]]), Xc_all[:, jb]):
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
        rows = _blocks(n, block, rng)
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
        best = _bic(float(ry @ ry), n, kb) - BIC_MARGIN
        for s in subsets:
            a = rc[:, index[s]]
            c, *_ = np.linalg.lstsq(a, ry, rcond=None)
            r = ry - a @ c
            b = _bic(float(r @ r), n, kb + len(s))
            if b < best:
                best, best_key = b, s
        for name in chosen:
            counts[name] += name in best_key
    return {k: v / max(reps, 1) for k, v in counts.items()}
