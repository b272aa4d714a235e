"""The discrepancy workflow on steady pump-bench tables (the pump-bench CSV format).

Users often have steady test points rather than time series: one row per point with
``p_in``, ``p_out``, ``n``, ``theta``, ``q`` (and ``replicate``), units in the column names
(:mod:`diagnostics.pump.csvio`).  At steady state the pump-outlet 0-junction of the rig
(paper 002 eqs. 1-5; Ṗ = 0) reads::

    ω·Vp − q = Δp/Rlp + Σ c_k·x_k(Δp, ω, μ(θ))        Δp = p_out − p_in   [m³/s]

so the ``pump_flow`` balance of :mod:`~diagnostics.discrepancy.balances` is evaluated on
the rows: target ``ω·Vp − q``, base columns ``Δp`` (laminar slip 1/Rlp) and ``ω`` (a
correction of the displacement), re-fitted unpenalised, and the library's ``pump_flow``
candidates.  Rows are independent, so the selection uses White's robust errors and an
ordinary (block length 1) bootstrap.  Several speeds separate a speed-reading offset
(constant) from a displacement error (∝ ω); several temperatures separate slip ∝ Δp/μ from
slip ∝ √Δp.

The stored pump is the rig's pump with the pump-outlet effects the rig already carries (an
earlier ``discover`` stored them): their flow is part of the model the rows are checked
against, they are no candidates, and a new effect is stored beside them, all restated for
the re-fitted displacement (:func:`~diagnostics.discrepancy.balances.carried`).

**Select on every row, confirm on the held-out edge** (DISCREPANCY.md, items 5 and 6).
The rows at the edge of the operating range are held out: the highest temperature when
there are two to :data:`LEVELS` of them, the top fifth of the temperatures when they spread
over a range (monitoring data), else the top fifth of the pressures.  The equation-error
selection (base re-fit, tests, BIC margin, practical size) reads every row, the edge
included, where an effect ∝ 1/μ is largest (held out before selection, the hottest level
cost such effects their power).  What it names is then confirmed: the named terms are
re-fitted on the training rows alone to the residual of the *stored* pump together with
corrections of the pump's own laminar slip and displacement (DISCREPANCY.md, item 3: a
stored pump is never exact, and an effect fitted against a fixed one takes up the pump's
error and reports an interval as if the pump were known), and kept when each is of its
entry's sign, the re-fitted pump is still a pump (1/Rlp and Vp positive), and the held-out
gap in excess of the scatter shrinks at least
:data:`~diagnostics.discrepancy.workflow.CONFIRM_RATIO`-fold against the stored pump — and
as much against the pump's own Rlp and Vp re-fitted alone, where that re-fit leaves more
than :data:`~diagnostics.discrepancy.verdict.OUTPUT_GAP` σ held out.  The significance is
the selection's, on every row.  Once confirmed, the terms and the pump are fitted again on
every row (each term significant there, |t| ≥ 2.576, White errors on columns scaled to
unit RMS: :func:`~diagnostics.discrepancy.pump_refit.robust_ols`), and that fit is stored:
the augmented rig carries the effect *and* the re-fitted Rlp and Vp (a bench table is the
pump's characterisation, not field data of a worn rig), the coefficient restated for the
re-fitted Vp where the element reads it (:mod:`~diagnostics.discrepancy.pump_refit`); the
message gives the held-out gap before, after (the training rows' re-fit, kept as
``traces["confirmation"]``: its coefficients and pump corrections, :func:`predict_flow`'s
``effects`` and ``base``), and with the pump re-fitted alone.  When no effect is named and
the pump re-fitted alone brings the held-out gap within
:data:`~diagnostics.discrepancy.verdict.OUTPUT_GAP` σ, the verdict is ``base drift`` (the
stored rig left as it is), as in the transient workflow.  Replicated points give the
lack-of-fit F-test (:mod:`~diagnostics.discrepancy.lof`) before and after, on every row,
and the scatter σ the held-out gaps are read in.  What each of these choices moved, on the
study's and the design notes' prototype tables and on the V32HL56 map, is in
``docs/discrepancy.md`` ("Steady pump-bench tables") and ``docs/real-data.md``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from diagnostics.discrepancy.balances import BALANCES, BASE_SIGNS, BalanceData, effects_of
from diagnostics.discrepancy.drift import Drift
from diagnostics.discrepancy.first_step import check_document
from diagnostics.discrepancy.gap import GapRow
from diagnostics.discrepancy.lof import lack_of_fit, permutation_p
from diagnostics.discrepancy.pump_refit import (
    BASE,
    base_change,
    bench_drift,
    combined,
    drifted,
    effect_flow,
    model_flow,
    on_refitted,
    refitted_pump,
    stored_effects,
    stored_fit,
    with_base,
)
from diagnostics.discrepancy.refit import with_effects
from diagnostics.discrepancy.selection import MIN_SAMPLES_PER_TERM, PRACTICAL, select
from diagnostics.discrepancy.signals import Signals
from diagnostics.discrepancy.verdict import OUTPUT_GAP, excess_ratio
from diagnostics.discrepancy.workflow import CONFIRM_RATIO, Discovery, NamedEffect
from diagnostics.pump.csvio import is_bench_table, read_bench_csv
from diagnostics.pump.data import BenchData
from sim.components.effects import EFFECTS
from sim.errors import InputError
from sim.rigs.assembly import Rig
from sim.rigs.schema import validate_rig_document

__all__ = ["discover_steady", "is_bench_table", "predict_flow", "read_bench_bytes",
           "require_rows"]

Arr = npt.NDArray[np.float64]
Progress = Callable[[float, str], None]

#: the channel name of the delivered flow in the report
FLOW = "q"
#: more oil temperatures than this (to 1 °C) are a spread, not a bench's levels [-]
LEVELS = 5
#: permutations of the lack-of-fit test's p-value (:func:`~diagnostics.discrepancy.lof.
#: permutation_p`), drawn with the workflow's ``seed`` [-]
PERMUTATIONS = 999
#: the source of a coefficient fitted here, in the augmented rig document
FITTED = ("fitted by hydrodiag discover (steady pump-bench table: least squares with the "
          "pump's Rlp and Vp)")


def read_bench_bytes(content: bytes, *, field: str = "file") -> BenchData:
    """A pump-bench CSV given as bytes (:func:`diagnostics.pump.csvio.read_bench_csv`;
    errors name the column, else ``field``)."""
    return read_bench_csv(content, field=field)


def _signals(bench: BenchData, rig: Rig, rows: npt.NDArray[np.int64]) -> Signals:
    dp = (bench.p_out - bench.p_in)[rows]
    values = {"P_pump": dp, "dP_pump": np.zeros(rows.size), "speed": bench.omega[rows],
              "Vp": np.full(rows.size, rig.base["pump.Vp"]), "T": bench.theta[rows],
              "mu": np.array([rig.fluid.dynamic_viscosity(float(t)) for t in bench.theta[rows]]),
              "Q_meter_B": bench.q[rows]}
    return Signals(values, np.zeros(rows.size, dtype=np.int64),
                   np.full(rows.size, "steady"), np.arange(rows.size, dtype=float), ["bench"])


def _balance(s: Signals, values: Mapping[str, float], circuit: str
             ) -> tuple[BalanceData, list[str]]:
    """The pump-outlet balance on steady rows, with the library's entries that apply to
    ``circuit`` and that the rig does not carry already (those are part of the stored pump,
    :func:`~diagnostics.discrepancy.balances.carried`); candidates that need signals a
    steady table has not are listed as skipped."""
    c = s.values
    stored = stored_effects(values)
    y = c["speed"] * c["Vp"] - c["Q_meter_B"] - effect_flow(s, stored)
    base = {"pump.Rlp": c["P_pump"], "pump.Vp": c["speed"]}
    cands: dict[str, Arr] = {}
    skipped: list[str] = []
    for e in effects_of("pump_flow"):
        if not e.entry.applies_to(circuit) or e.name in stored:
            continue
        try:
            cands[e.name] = np.asarray(e.entry.regressor(c), dtype=float)
        except KeyError:
            skipped.append(e.name)
    pump = next(b for b in BALANCES if b.name == "pump_flow")
    full = float(values["pump.speed"] * values["pump.Vp"])
    return (BalanceData(pump, y, base, cands, np.ones(y.size, dtype=bool), full,
                        {k: v for k, v in BASE_SIGNS.items() if k in base}), skipped)


def _split(bench: BenchData) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    n = bench.q.size
    temps = np.round(bench.theta)
    if np.unique(temps).size > LEVELS:
        # temperatures spread over a range (field or monitoring data): its top fifth
        held = bench.theta >= np.quantile(bench.theta, 0.8)
    elif np.unique(temps).size >= 2:
        held = temps == temps.max()
    else:
        dp = bench.p_out - bench.p_in
        held = dp >= np.quantile(dp, 0.8)
    if held.all() or not held.any() or n - int(held.sum()) < 6:
        return np.arange(n), np.arange(n)
    return np.flatnonzero(~held), np.flatnonzero(held)


def _groups(bench: BenchData, rows: npt.NDArray[np.int64]) -> list[tuple[float, float, float]]:
    """Condition of each row: Δp to 0.1 bar, speed to 0.1 rad/s, temperature to 0.5 °C."""
    dp = bench.p_out - bench.p_in
    return [(round(float(dp[i]) / 1e4), round(float(bench.omega[i]) * 10),
             round(float(bench.theta[i]) * 2)) for i in rows]


def predict_flow(rig_document: Mapping[str, Any], bench: BenchData,
                 effects: Mapping[str, float] | None = None,
                 base: Mapping[str, float] | None = None) -> Arr:
    """Flow of the rig's pump at every bench row, plus ``effects`` [m³/s].

    ``q = ω·Vp − Δp/Rlp − Σ k·x_k`` (paper 002 eqs. 1-5 at steady state) at the rows'
    logged speed, pressure and temperature; ``effects`` maps effect name → coefficient [SI];
    ``base`` corrects the pump's own laminar slip and displacement in
    :func:`~diagnostics.discrepancy.pump_refit.model_flow`'s form (a conductance added to
    1/Rlp, a displacement taken off Vp: the ``confirmation`` re-fit that
    :func:`discover_steady` leaves in its traces).
    """
    rig = Rig.from_spec(validate_rig_document(dict(rig_document)))
    s = _signals(bench, rig, np.arange(bench.q.size))
    return model_flow(rig.values(), s, effects or {}, base)


def _physical(values: Mapping[str, float], coefs: Mapping[str, float],
              base: Mapping[str, float]) -> bool:
    """Every fitted effect of its entry's sign and the re-fitted pump still a pump (1/Rlp
    and Vp positive)."""
    return (all(EFFECTS[n].entry.sign * k >= 0.0 for n, k in coefs.items())
            and all(v > 0.0 for v in refitted_pump(values, base).values()))


def _gap(meas: Arr, model: Arr) -> list[GapRow]:
    e = model - meas
    return [GapRow(FLOW, "m^3/s", "steady", float(np.sqrt(np.mean(e * e))),
                   float(np.max(np.abs(e))))]


def require_rows(bench: BenchData) -> None:
    """Raise :class:`InputError` (``field="file"``) for a table too small for the workflow:
    fewer than 8 rows, or fewer training rows (those not held out) than the pump balance's
    selection needs (:data:`~diagnostics.discrepancy.selection.MIN_SAMPLES_PER_TERM` per
    term: the two base terms and two candidates).  Cheap: called before a job starts."""
    if bench.q.size < 8:
        raise InputError(f"a bench table needs at least 8 rows, got {bench.q.size}",
                         field="file")
    train, _ = _split(bench)
    need = MIN_SAMPLES_PER_TERM * (len(BASE) + 2)
    if train.size < need:
        raise InputError(f"{bench.q.size} rows leave {train.size} to fit once the edge of the "
                         f"operating range is held out; the pump balance needs {need} (more "
                         "test points, or more records)", field="file")


def discover_steady(rig_document: Mapping[str, Any], bench: BenchData, *,
                    progress: Progress | None = None, bootstrap: int = 30,
                    seed: int = 0) -> Discovery:
    """The discrepancy workflow on steady pump test points (module docstring).

    Parameters
    ----------
    rig_document
        The rig as stored; its pump is the model checked.
    bench
        Steady test points (:func:`read_bench_bytes`, :func:`diagnostics.pump.csvio.read_bench_csv`).
    progress
        Called with (fraction done, what).
    bootstrap, seed
        Bootstrap replicates for the inclusion frequencies and their seed (also the seed
        of the lack-of-fit permutation test); both are in the report's ``randomness``.

    Raises
    ------
    InputError
        Fewer than 8 rows (``field="file"``).
    """
    def report(frac: float, what: str) -> None:
        if progress is not None:
            progress(frac, what)

    check_document(rig_document)
    require_rows(bench)
    doc = dict(rig_document)
    rig = Rig.from_spec(validate_rig_document(doc))
    values = rig.values()
    train_i, held_i = _split(bench)
    every_i = np.arange(bench.q.size)
    train, held = _signals(bench, rig, train_i), _signals(bench, rig, held_i)
    every = _signals(bench, rig, every_i)
    report(0.1, "equation-error residuals of the pump outlet")
    # the selection reads every row, the edge included (where an effect ∝ 1/μ is largest);
    # what it names is then re-fitted on the training rows and checked on the held-out ones
    data, skipped = _balance(every, values, rig.circuit.name)
    sel = select(data, bootstrap=bootstrap, seed=seed, lags=0, block=1)
    report(0.6, "selection done")
    groups = _groups(bench, every_i)
    lof_before = lack_of_fit(sel.base_residual, groups, len(data.base))
    pe = lof_before.sigma_pe if lof_before is not None else float(
        np.sqrt(np.mean(sel.residual ** 2)))
    sigma = {FLOW: max(pe, 1e-12)}
    meas = held.values["Q_meter_B"]
    gap_before = _gap(meas, model_flow(values, held, {}))
    named: list[NamedEffect] = []
    fitted: dict[str, float] = {}
    refitted: dict[str, float] = {}
    rejected: list[str] = []
    not_beating = ""
    # the training rows' re-fit whose held-out gap confirmed or rejected a chosen term
    confirmation: dict[str, dict[str, float]] = {}
    gap_after: list[GapRow] = []
    # the stored pump's own laminar slip and displacement re-fitted alone (reported)
    _, _, alone = stored_fit(values, train, [])
    gap_alone = _gap(meas, model_flow(values, held, {}, alone))
    if sel.chosen is not None:
        names = [t.effect for t in sel.chosen.terms]
        # confirmation (DISCREPANCY.md, item 6): the named terms and the pump's own slip and
        # displacement re-estimated on the training rows alone, predicting the held-out edge
        coefs, errs, base = stored_fit(values, train, names)
        trial = _gap(meas, model_flow(values, held, coefs, base))
        confirmation = {"coefficients": dict(coefs), "base": dict(base)}
        # of the entry's sign with the pump re-fitted too (its significance is the
        # selection's, on every row: on the training rows alone a 2 % FS viscous slip at
        # 1 % FS noise reads |t| ≈ 0.7-4), and shrinking the held-out gap of the stored pump
        valid = _physical(values, coefs, base)
        # and, where the pump's own slip and displacement re-fitted alone leave a held-out
        # gap above OUTPUT_GAP σ, shrinking that too (a warm-up slice of the ZeMA data named
        # a viscous slip at 3.6 σ held out against 3.7 σ for the pump re-fitted alone, and
        # stored it); where the re-fit alone already reaches the scatter, the held-out rows
        # cannot tell the two apart and the selection's significance decides
        beats_alone = (gap_alone[0].rmse <= OUTPUT_GAP * sigma[FLOW]
                       or excess_ratio(gap_alone, trial, sigma) >= CONFIRM_RATIO)
        confirmed = (valid and beats_alone
                     and excess_ratio(gap_before, trial, sigma) >= CONFIRM_RATIO)
        if confirmed:
            # confirmed: the stored coefficient is re-fitted on every row, the selection's
            # (significant there, of the entry's sign, the pump still a pump)
            coefs, errs, base = stored_fit(values, every, names)
            confirmed = _physical(values, coefs, base) and all(
                abs(coefs[n]) >= 2.576 * errs[n] for n in names)
        if confirmed:
            # the augmented rig carries every pump-outlet effect: those it had, with a
            # named one's fitted increment added, restated for the re-fitted Vp
            errs = {n: errs.get(n, 0.0) for n in combined(values, coefs)}
            coefs, errs = on_refitted(values, base, every, combined(values, coefs), errs)
            fitted, refitted, gap_after = coefs, base, trial
            for t in sel.chosen.terms:
                e = EFFECTS[t.effect]
                decl = e.parameter(e.entry.coefficient)
                assert decl is not None
                v, err = coefs[t.effect], errs[t.effect]
                lo, hi = e.entry.plausible
                named.append(NamedEffect(
                    t.effect, sel.balance, e.entry.explanation, e.entry.reference,
                    e.entry.signature, e.entry.coefficient, decl.unit, t.coefficient, v,
                    (v - 1.96 * err, v + 1.96 * err), bool(lo <= v <= hi), (lo, hi), t.t,
                    sel.inclusion.get(t.effect, float("nan")), sel.competing,
                    [g for g in sel.ambiguity if t.effect in g]))
        else:
            rejected = names
            if valid and not beats_alone:
                not_beating = (f"held out it leaves {trial[0].rmse / sigma[FLOW]:.1f} σ "
                               f"against {gap_alone[0].rmse / sigma[FLOW]:.1f} σ for the "
                               "pump re-fitted alone")
    report(0.9, "held-out check")
    lof_after = lack_of_fit(sel.residual, groups,
                            len(data.base) + len(fitted)) if named else None
    new_doc = with_effects(with_base(doc, values, refitted),
                           {f"{n}.{EFFECTS[n].entry.coefficient}": v
                            for n, v in fitted.items()}, source=FITTED) if fitted else dict(doc)
    validate_rig_document(new_doc)  # the augmented rig must load as any stored rig
    practical = PRACTICAL * data.full_scale
    # significant, and larger than the practical size beyond what the scatter gives the
    # condition means (rms_lof alone is ≈ σ/√2 on pure noise, above the practical size)
    # and, since bench scatter is often heavy-tailed, significant by permutation too
    misfit = (lof_before is not None and lof_before.p < 0.01
              and lof_before.rms_excess > practical
              and permutation_p(sel.base_residual, groups, permutations=PERMUTATIONS,
                                seed=seed) < 0.01)
    off = gap_before[0].rmse > OUTPUT_GAP * sigma[FLOW]
    drift: Drift | None = None
    if named:
        outcome = "named" if len(named) == 1 else "partially explained"
        message = f"named {', '.join(n.name for n in named)}"
        message += (f"; held-out flow RMSE {gap_before[0].rmse / sigma[FLOW]:.1f} σ → "
                    f"{gap_after[0].rmse / sigma[FLOW]:.1f} σ fitted without those rows (the "
                    f"pump re-fitted alone: {gap_alone[0].rmse / sigma[FLOW]:.1f} σ); stored as "
                    f"fitted on every row, with the {base_change(values, refitted)}")
        if len(named) > 1:
            message += "; partially explained — possibly outside the library (two terms)"
    elif off and drifted(values, alone, gap_alone[0].rmse, sigma[FLOW]):
        outcome = "base drift"
        gap_after = gap_alone
        drift = bench_drift(values, train, gap_alone, sigma[FLOW])
        message = (f"no new effect: the held-out flow differs from the stored pump's "
                   f"({gap_before[0].rmse / sigma[FLOW]:.1f} σ) and the pump's own laminar "
                   f"slip and displacement, re-fitted alone, close the gap "
                   f"({gap_alone[0].rmse / sigma[FLOW]:.1f} σ; {base_change(values, alone)}). "
                   + ("A pump leakage that moved in service is wear (POST /diagnose sizes it "
                      "against the stored rig)" if rig.circuit.cycle else
                      "A pump leakage that moved in service is wear (this rig has no cylinder "
                      "cycle to diagnose: the re-fitted Rlp above is its size)")
                   + "; a stored pump that never matched this bench is re-characterised "
                   "(hydrodiag calibrate pump; hydrodiag rigs update). The stored rig is "
                   "left as it is")
    elif misfit or off:
        outcome = "unexplained"
        message = ("model and data differ (lack of fit against the repeats"
                   + (f" p = {lof_before.p:.2g}" if lof_before is not None else "")
                   + f"; held-out flow RMSE {gap_before[0].rmse / sigma[FLOW]:.1f} σ) but no "
                   "library effect explains it: possibly outside the library, or a drift of "
                   "base parameters that the stored rig does not have")
    else:
        outcome = "no effect"
        message = "no effect found: the gap is within the scatter and the practical size"
    if not named and off and outcome != "base drift":
        message += (f"; the pump's own parameters re-fitted alone ({base_change(values, alone)}) "
                    f"leave a held-out flow RMSE of {gap_alone[0].rmse / sigma[FLOW]:.1f} σ")
    if rejected and not_beating:
        message += (f"; not confirmed: {', '.join(rejected)} (no better than the pump's own "
                    f"parameters re-fitted: {not_beating})")
    elif rejected:
        message += ("; not confirmed (re-fitted: of the wrong sign or not significant, or "
                    "the pump leaking negatively; or, fitted without the held-out rows, not "
                    "shrinking their gap): "
                    f"{', '.join(rejected)}")
    if skipped:
        message += f"; not computable from a steady table: {', '.join(skipped)}"
    lof = {"before": lof_before.to_dict() if lof_before else None,
           "after": lof_after.to_dict() if lof_after else None}
    report(1.0, outcome)
    return Discovery(
        outcome, message, named, [sel],
        [f"bench rows {_ranges(train_i)}"
         + (" (the selection: every row)" if held_i.size < bench.q.size else "")],
        [f"bench rows {_ranges(held_i)}"], gap_before, gap_after, {}, {}, new_doc,
        "no simulation: steady pump-outlet balance (paper 002 eqs. 1-5, Ṗ = 0)",
        {sel.balance: sel.detectable},
        {"selections": [sel], "data": [data], "signals": every, "gap_alone": gap_alone,
         "sigma": sigma[FLOW], "confirmation": confirmation}, lof, drift,
        randomness={"seed": seed, "bootstrap": bootstrap, "permutations": PERMUTATIONS})


def _ranges(rows: npt.NDArray[np.int64]) -> str:
    """``0-11, 24-35``: row indices as ranges."""
    if rows.size == 0:
        return "none"
    out, start, prev = [], int(rows[0]), int(rows[0])
    for r in rows[1:]:
        r = int(r)
        if r != prev + 1:
            out.append(f"{start}-{prev}" if prev > start else f"{start}")
            start = r
        prev = r
    out.append(f"{start}-{prev}" if prev > start else f"{start}")
    return ", ".join(out)
