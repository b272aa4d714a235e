"""The discrepancy workflow: find where model and data disagree, name the missing effect,
add it to the rig, and show the gap shrink on held-out data (issue 8).

Steps (DISCREPANCY.md):

1. split the records: the record at the *edge* of the operating range (highest load, then
   highest temperature) is held out when there are at least two;
2. equation-error residuals of the rig's junction balances on the training records, base
   parameters re-fitted unpenalised (:mod:`~diagnostics.discrepancy.balances`);
3. selection per balance (:mod:`~diagnostics.discrepancy.selection`);
4. every named effect goes into a new rig document (``effects:`` section) with its
   coefficient re-fitted in output-error form by re-simulating the training records
   (scipy ``least_squares``);
5. gap before/after on the held-out record (RMSE and max per output and region) and
   whiteness (Ljung-Box) before/after.

"No effect" and "unexplained" are results: with nothing named, the report gives each
candidate's minimum detectable size; a balance whose residual is still structured
(Ljung-Box p < 0.01 with an RMS above the practical size) without an admissible library
explanation is reported as *outside the library*.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy.ndimage import uniform_filter1d
from scipy.optimize import least_squares

from diagnostics.discrepancy.balances import balance_data
from diagnostics.discrepancy.gap import GapRow, aligned_residuals, gap_table, ljung_box_p
from diagnostics.discrepancy.selection import PRACTICAL, Selection, select
from diagnostics.discrepancy.signals import condition_of, prepare
from diagnostics.discrepancy.simulate import SOLVER, on_grid, simulate, solver_error
from diagnostics.timeseries import SeriesRecord
from sim.components.effects import EFFECTS
from sim.errors import InputError, SimulationError
from sim.rigs.assembly import Rig
from sim.rigs.schema import validate_rig_document

__all__ = ["Discovery", "NamedEffect", "discover"]

Arr = npt.NDArray[np.float64]
Progress = Callable[[float, str], None]

#: measured channels compared in output-error form, when present
#: held-out excess-gap ratio an added effect must reach to be kept
CONFIRM_RATIO = 1.5
#: held-out steady RMSE, in units of the channel's noise σ, above which an unnamed gap is
#: reported as unexplained rather than "no effect"
OUTPUT_GAP = 3.0

OUTPUTS = ("P1", "P2", "v", "P_pump", "P_valve_P", "Q_meter_B", "Q_meter_C")


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
    """Outcome of :func:`discover` (``to_dict`` gives the JSON report)."""

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

    def to_dict(self) -> dict[str, Any]:
        """The report as JSON-able data (units in the keys' descriptions)."""
        def sel_dict(s: Selection) -> dict[str, Any]:
            return {
                "balance": s.balance, "unit": s.unit,
                "chosen": [t.effect for t in s.chosen.terms] if s.chosen else [],
                "bic_gain": s.bic_gain, "competing": s.competing, "ambiguity": s.ambiguity,
                "inclusion": s.inclusion,
                "base_coefficients": s.base_coefficients,
                "residual_rms": float(np.sqrt(np.mean(s.base_residual ** 2))),
                "practical_size": PRACTICAL * s.full_scale,
                "candidates": {k: {"coefficient": t.coefficient, "stderr": t.stderr, "t": t.t,
                                   "p": t.p, "rms_contribution": t.rms_contribution,
                                   "plausible": t.plausible} for k, t in s.singles.items()},
                "minimum_detectable_rms": {k: (v if math.isfinite(v) else None)
                                           for k, v in s.detectable.items()},
                "rejections": s.chosen.reasons if s.chosen else [],
            }

        def gap(rows: list[GapRow]) -> list[dict[str, Any]]:
            return [{"channel": r.channel, "unit": r.unit, "region": r.region, "rmse": r.rmse,
                     "max_abs": r.max_abs} for r in rows]

        return {
            "verdict": self.verdict, "message": self.message,
            "named": [vars(n) | {"interval": list(n.interval),
                                 "plausible_range": list(n.plausible_range)}
                      for n in self.named],
            "balances": [sel_dict(s) for s in self.selections],
            "training_records": self.training, "held_out_records": self.held_out,
            "gap_before": gap(self.gap_before), "gap_after": gap(self.gap_after),
            "whiteness_before": self.whiteness_before, "whiteness_after": self.whiteness_after,
            "rig_document": self.rig_document, "solver": self.solver,
        }


def _split(records: Sequence[SeriesRecord], rig: Rig) -> tuple[list[int], list[int]]:
    if len(records) < 2:
        return [0], []
    key = [(condition_of(r, rig).load, condition_of(r, rig).oil_temperature) for r in records]
    edge = max(range(len(records)), key=lambda i: key[i])
    return [i for i in range(len(records)) if i != edge], [edge]


def _with_effects(doc: Mapping[str, Any], values: Mapping[str, float]) -> dict[str, Any]:
    """A copy of ``doc`` whose ``effects:`` section holds ``values`` (``effect.param → SI``)."""
    out = copy.deepcopy(dict(doc))
    effects = dict(out.get("effects") or {})
    for key, value in values.items():
        name, _, pname = key.partition(".")
        decl = EFFECTS[name].parameter(pname)
        assert decl is not None
        body = dict(effects.get(name) or {})
        params = dict(body.get("parameters") or {})
        params[pname] = {"value": float(value), "unit": decl.unit,
                         "source": "fitted by hydrodiag discover (output error, re-simulated)"}
        body["parameters"] = params
        effects[name] = body
    out["effects"] = effects
    return out


def _channels(records: Sequence[SeriesRecord]) -> list[str]:
    return [c for c in OUTPUTS if c in records[0].channels]


def _sigmas(records: Sequence[SeriesRecord], channels: Sequence[str]) -> dict[str, float]:
    from diagnostics.discrepancy.gap import noise_sigma

    out = {}
    for c in channels:
        s = float(np.median([noise_sigma(r.channels[c]) for r in records]))
        scale = float(np.max([np.max(np.abs(r.channels[c])) for r in records]))
        out[c] = max(s, 1e-4 * scale, 1e-30)
    return out


def _stacked_residual(rig: Rig, records: Sequence[SeriesRecord], channels: Sequence[str],
                      sig: Mapping[str, float], overrides: Mapping[str, float]) -> Arr:
    """Model − measurement / σ over the steady part (10-90 %) of each measured phase.

    A fixed set of samples (every 10th measured sample, time since phase start) whatever
    the simulated phase lasts, so the vector has one length for the optimiser; a model
    phase that ends earlier holds its last value there.
    """
    parts = []
    for r in records:
        table = simulate(rig, condition_of(r, rig), overrides)
        phases = r.phase if r.phase is not None else np.full(r.t.size, "working")
        for ph in ("working", "return"):
            sel = np.flatnonzero(phases == ph)
            tab = table[table["phase"] == ph]
            if sel.size < 20 or len(tab) < 3:
                continue
            tm = r.t[sel] - r.t[sel][0]
            keep = (tm >= 0.1 * tm[-1]) & (tm <= 0.9 * tm[-1])
            idx = sel[keep][::10]
            ts = tab["t [s]"].to_numpy(dtype=float)
            model = on_grid(tab.assign(**{"t [s]": ts - ts[0]}), tm[keep][::10], list(channels))
            for c in channels:
                parts.append((model[c] - r.channels[c][idx]) / sig[c])
    return np.concatenate(parts) if parts else np.zeros(1)


def _refit(doc: dict[str, Any], start: Mapping[str, float], records: Sequence[SeriesRecord],
           channels: Sequence[str], sig: Mapping[str, float], max_nfev: int
           ) -> tuple[dict[str, float], dict[str, float]]:
    """Output-error re-fit of the effect coefficients; returns (values, 1-σ errors)."""
    rig = Rig.from_spec(validate_rig_document(_with_effects(doc, start)))
    keys = list(start)
    scale = np.array([abs(v) if v != 0 else 1.0 for v in start.values()])

    def fun(z: Arr) -> Arr:
        ov = {k: float(zi * s) for k, zi, s in zip(keys, z, scale, strict=True)}
        try:
            return _stacked_residual(rig, records, channels, sig, ov)
        except (SimulationError, InputError):
            return np.full(_n[0], 1e3)

    _n = [0]
    r0 = fun(np.ones(len(keys)))
    _n[0] = r0.size
    lo, hi = [], []
    for k in keys:
        name, _, pname = k.partition(".")
        decl = EFFECTS[name].parameter(pname)
        assert decl is not None
        lo.append(-np.inf if decl.lower is None else decl.lower)
        hi.append(np.inf if decl.upper is None else decl.upper)
    lb = np.array(lo) / scale
    ub = np.array(hi) / scale
    z0 = np.clip(np.ones(len(keys)), lb + 1e-12, ub - 1e-12)
    sol = least_squares(fun, z0, bounds=(lb, ub), x_scale=1.0, diff_step=0.05,
                        max_nfev=max_nfev)
    values = {k: float(z * s) for k, z, s in zip(keys, sol.x, scale, strict=True)}
    J = sol.jac
    dof = max(sol.fun.size - len(keys), 1)
    s2 = float(sol.fun @ sol.fun) / dof
    try:
        cov = np.linalg.inv(J.T @ J) * s2
        err = {k: float(math.sqrt(max(cov[i, i], 0.0)) * scale[i]) for i, k in enumerate(keys)}
    except np.linalg.LinAlgError:
        err = dict.fromkeys(keys, float("nan"))
    return values, err


def discover(rig_document: Mapping[str, Any], records: Sequence[SeriesRecord], *,
             progress: Progress | None = None, refit: bool = True, max_nfev: int = 8,
             bootstrap: int = 30, seed: int = 0) -> Discovery:
    """Run the discrepancy workflow (module docstring) on ``records`` of a rig.

    Parameters
    ----------
    rig_document
        The rig as stored (a validated rig document); the workflow starts from it.
    records
        Measured cycles (:func:`diagnostics.timeseries.read_series`), several loads or
        temperatures where possible.
    progress
        Called with (fraction done, what) as the steps complete.
    refit
        Re-fit the named coefficients in output-error form (else keep the equation-error
        estimates).
    max_nfev
        Simulation budget of the output-error re-fit.
    bootstrap
        Bootstrap replicates for the inclusion frequencies.
    seed
        Seed of the bootstrap.

    Raises
    ------
    InputError
        No records, channels that differ between records, none of the balances computable.
    """
    def report(frac: float, what: str) -> None:
        if progress is not None:
            progress(frac, what)

    doc = dict(rig_document)
    rig = Rig.from_spec(validate_rig_document(doc))
    if not records:
        raise InputError("no records to analyse", field="file")
    train_i, held_i = _split(records, rig)
    train = [records[i] for i in train_i]
    held = [records[i] for i in held_i] or train
    report(0.05, "equation-error residuals")
    signals = prepare(train, rig)
    data = balance_data(signals, rig.values())
    if not data:
        raise InputError("the records lack the channels of every balance (need e.g. P1, P2, v "
                         "for the piston force, or Q_meter_B, P_pump for the pump)",
                         field="file")
    selections = [select(d, bootstrap=bootstrap, seed=seed) for d in data]
    report(0.3, "selection done")
    rate = 1000.0
    named: list[NamedEffect] = []
    channels = _channels(records)
    sig = _sigmas(records, channels)
    base_tables = [simulate(rig, condition_of(r, rig)) for r in held]
    gap_before = [row for r, t in zip(held, base_tables, strict=True)
                  for row in gap_table(r, t, channels)]
    values: dict[str, float] = {}
    errors: dict[str, float] = {}
    rejected: list[str] = []
    chosen = [s for s in selections if s.chosen is not None]
    for k, s in enumerate(chosen):
        # each balance's explanation is confirmed on its own, in output-error form
        assert s.chosen is not None
        start = {f"{t.effect}.{EFFECTS[t.effect].entry.coefficient}": t.coefficient
                 for t in s.chosen.terms}
        report(0.35 + 0.4 * k / len(chosen), f"output-error re-fit of {', '.join(start)}")
        if refit:
            fitted, fit_err = _refit(doc, start, train, channels, sig, max_nfev)
        else:
            fitted, fit_err = dict(start), {key: float("nan") for key in start}
        significant = all(not math.isfinite(fit_err[key])
                          or abs(fitted[key]) >= 2.576 * fit_err[key] for key in fitted)
        trial = Rig.from_spec(validate_rig_document(_with_effects(doc, fitted)))
        trial_gap = [row for r in held
                     for row in gap_table(r, simulate(trial, condition_of(r, trial)), channels)]
        if significant and excess_ratio(gap_before, trial_gap, sig) >= CONFIRM_RATIO:
            values.update(fitted)
            errors.update(fit_err)
        else:
            rejected += [t.effect for t in s.chosen.terms]
    new_doc = _with_effects(doc, values) if values else copy.deepcopy(doc)
    for s in selections:
        if s.chosen is None:
            continue
        for term in s.chosen.terms:
            e = EFFECTS[term.effect]
            key = f"{term.effect}.{e.entry.coefficient}"
            if key not in values:
                continue
            decl = e.parameter(e.entry.coefficient)
            assert decl is not None
            value, err = values[key], errors[key]
            if not math.isfinite(err):
                err = term.stderr
            lo, hi = e.entry.plausible
            named.append(NamedEffect(
                term.effect, s.balance, e.entry.explanation, e.entry.reference,
                e.entry.signature, e.entry.coefficient, decl.unit, term.coefficient, value,
                (value - 1.96 * err, value + 1.96 * err), bool(lo <= value <= hi), (lo, hi),
                term.t, s.inclusion.get(term.effect, float("nan")),
                s.competing, [g for g in s.ambiguity if term.effect in g]))
    report(0.8, "held-out check")
    white_before = _whiteness(held, base_tables, channels, rate)
    traces: dict[str, Any] = {"held": held[0], "before": base_tables[0], "channels": channels,
                              "selections": selections, "signals": signals, "data": data}
    if named:
        new_rig = Rig.from_spec(validate_rig_document(new_doc))
        after_tables = [simulate(new_rig, condition_of(r, new_rig)) for r in held]
        gap_after = [row for r, t in zip(held, after_tables, strict=True)
                     for row in gap_table(r, t, channels)]
        white_after = _whiteness(held, after_tables, channels, rate)
        traces["after"] = after_tables[0]
    else:
        gap_after, white_after = [], {}
    verdict, message = _verdict(named, selections, gap_before, gap_after, white_after, sig)
    if rejected:
        message += ("; not confirmed by re-simulation (output-error coefficient not "
                    f"significant or held-out gap not shrinking): {', '.join(rejected)}")
    report(1.0, verdict)
    detectable = {s.balance: s.detectable for s in selections}
    return Discovery(verdict, message, named, selections, [r.name for r in train],
                     [r.name for r in records] and [records[i].name for i in held_i],
                     gap_before, gap_after, white_before, white_after, new_doc,
                     _solver_statement(base_tables), detectable, traces)


def _whiteness(records: Sequence[SeriesRecord], tables: Sequence[Any], channels: Sequence[str],
               rate: float) -> dict[str, float]:
    out: dict[str, float] = {}
    for c in channels:
        ps = []
        for r, t in zip(records, tables, strict=True):
            res = aligned_residuals(r, t, [c])[c]
            for tt, e, _ in res.values():
                keep = (tt >= 0.1 * tt[-1]) & (tt <= 0.9 * tt[-1]) if tt.size else tt > 0
                ps.append(ljung_box_p(e[keep], rate=rate))
        vals = [p for p in ps if math.isfinite(p)]
        out[c] = float(min(vals)) if vals else float("nan")
    return out


def excess_ratio(before: Sequence[GapRow], after: Sequence[GapRow],
                 sigma: Mapping[str, float]) -> float:
    """Held-out gap in excess of the noise, before/after, over the steady regions.

    Excess = √(Σ max(RMSE² − σ², 0)/σ²) over the channels; a model that reaches the noise
    floor has no excess, so the ratio is what 'the gap shrank' can mean near the noise.
    """
    def excess(rows: Sequence[GapRow]) -> float:
        return math.sqrt(sum(max(r.rmse ** 2 - sigma[r.channel] ** 2, 0.0) / sigma[r.channel] ** 2
                             for r in rows if r.region == "steady"))

    b, a = excess(before), excess(after)
    if a == 0.0:
        return float("inf") if b > 0 else 1.0
    return b / a


def gap_ratio(before: Sequence[GapRow], after: Sequence[GapRow]) -> float:
    """Held-out RMSE ratio before/after on the channel and region with the largest gap before,
    measured in units of that channel's RMSE (the headline 'gap shrank by N×')."""
    if not before or not after:
        return float("nan")
    worst = max(before, key=lambda r: r.rmse / (max(b.rmse for b in before
                                                    if b.channel == r.channel) or 1.0)
                if r.region == "steady" else -1.0)
    match = [a for a in after if a.channel == worst.channel and a.region == worst.region]
    if not match or match[0].rmse == 0:
        return float("inf")
    return worst.rmse / match[0].rmse


def _structured(s: Selection) -> bool:
    """Whether a balance's residual is more than noise: Ljung-Box p < 0.01 on the residual
    every 20 samples and a low-passed (50 ms mean) RMS above 2× the practical size."""
    r = s.residual
    if r.size < 200:
        return False
    smooth = uniform_filter1d(r, 51)
    big = float(np.sqrt(np.mean(smooth ** 2))) > 2 * PRACTICAL * s.full_scale
    p = ljung_box_p(r, rate=1000.0)
    return bool(big and math.isfinite(p) and p < 0.01)


def _verdict(named: list[NamedEffect], selections: list[Selection], before: list[GapRow],
             after: list[GapRow], white_after: dict[str, float],
             sigma: Mapping[str, float]) -> tuple[str, str]:
    structured = [s.balance for s in selections if _structured(s)]
    # output-error gap on the held-out record, steady motion, in units of the noise
    off = [f"{r.channel} ({r.rmse / sigma[r.channel]:.1f} σ)" for r in before
           if r.region == "steady" and r.rmse > OUTPUT_GAP * sigma[r.channel]]
    if named:
        names = ", ".join(n.name for n in named)
        if len(named) > 1 or structured:
            return ("partially explained",
                    f"named {names}; partially explained — possibly outside the library "
                    f"(residual still above the practical size in: "
                    f"{', '.join(structured) or 'none'}; two or more terms)")
        return "named", f"named {names}"
    if structured or off:
        where = ", ".join([f"balance {b}" for b in structured] + off)
        return ("unexplained",
                f"model and data differ ({where}, held-out steady RMSE) but no library "
                "effect explains it: possibly outside the library, or a drift of base "
                "parameters that the stored rig does not have")
    return "no effect", "no effect found: the gap is within the noise and the practical size"


def _solver_statement(tables: list[pd.DataFrame]) -> str:
    """How the workflow simulated, and the largest solver error it reached, in σ."""
    worst = solver_error(tables)
    if not worst:
        return SOLVER
    errors = ", ".join(f"{k} {v:.2g} σ" for k, v in sorted(worst.items()))
    return f"{SOLVER}; estimated solver error at most {errors} of the sensors' noise"
