"""Output-error re-fit of named effects by re-simulating the training records.

An effect named in equation-error form (:mod:`~diagnostics.discrepancy.selection`) goes
into a copy of the rig document (its ``effects:`` section) and its coefficient is
re-estimated by least squares on model − measurement (scipy ``least_squares``, trust-region
reflective within the parameter's declared bounds) over the steady part of every measured
phase (10-90 %), each channel in units of its noise σ.  An entry whose signature is in
the pressure build-up after a valve switch (``EffectEntry.window == "build-up"``:
entrained air) starts from the bottom of its valley over 0-90 % of each phase (a log grid
around the equation-error estimate, then a bounded 1-D search to 1 %), and is refined
over 10-90 %.  The 1-σ errors come from the Jacobian at the
solution (:func:`fit_cov`: the widest of the residual variance's, a cluster-robust
sandwich over the phases, and the solver's resolution).

Each phase (and a dwell's stop) is compared on its own clock: the record's from midway
between its first sample and the one before (:func:`~diagnostics.discrepancy.simulate.
phase_start`), the model's from the switch event its solver stepped to, and the segment's
start then placed within its sample (:func:`_within_sample`, the model read up to half a
sample period earlier or later).  Before, both clocks started at their first sample: on
noise-free 1 kHz records of a worn piston the truth cost χ² 176 (the position 0.41 σ RMS
off, a whole phase shifted by up to a sample), now 0.10 (every channel within 0.005 σ).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy.optimize import least_squares, minimize_scalar

from diagnostics.discrepancy.simulate import (
    AT_STOP,
    despiked,
    model_origin,
    model_phase_start,
    on_grid,
    phase_segments,
    phase_start,
    record_kind,
    simulate_record,
)
from diagnostics.robust import cluster_cov
from diagnostics.timeseries import SeriesRecord
from sim.components.effects import EFFECTS, parameter_bounds
from sim.errors import InputError, SimulationError
from sim.rigs.assembly import Rig
from sim.rigs.schema import validate_rig_document

__all__ = ["APART", "NUMERICAL", "compare_from", "fit_cov", "output_cost", "refit",
           "residual_parts", "stacked", "stacked_residual", "tell_apart", "with_effects"]

Arr = npt.NDArray[np.float64]


#: log grid of the build-up re-fit's start: from 1/GRID_SPAN to GRID_SPAN/10 times the
#: equation-error estimate, GRID_POINTS points
GRID_SPAN = 30.0
GRID_POINTS = 15
#: scan of the compared part's cost around the located valley: ±LOCAL_SPAN in log
#: (a factor 1.32 either way, about the grid's spacing), LOCAL_POINTS points (4.7 % apart)
LOCAL_SPAN = 0.28
LOCAL_POINTS = 13


#: the source of a parameter fitted by re-simulation
RESIMULATED = "fitted by hydrodiag discover (output error, re-simulated)"


def with_effects(doc: Mapping[str, Any], values: Mapping[str, float], *,
                 source: str = RESIMULATED) -> dict[str, Any]:
    """A copy of ``doc`` whose ``effects:`` section holds ``values`` (``effect.param → SI``),
    each with ``source`` (how it was fitted)."""
    out = copy.deepcopy(dict(doc))
    effects = dict(out.get("effects") or {})
    for key, value in values.items():
        name, _, pname = key.partition(".")
        decl = EFFECTS[name].parameter(pname)
        assert decl is not None
        body = dict(effects.get(name) or {})
        params = dict(body.get("parameters") or {})
        params[pname] = {"value": float(value), "unit": decl.unit,
                         "source": source}
        body["parameters"] = params
        effects[name] = body
    out["effects"] = effects
    return out



def compare_from(keys: Sequence[str]) -> float:
    """Start of the compared part of each phase [fraction of the phase] for the effect
    parameters ``keys`` (``effect.param``): 0 when one of the effects declares its
    signature in the build-up after a switch, else 0.1 (module docstring)."""
    builds = any(EFFECTS[k.partition(".")[0]].entry.window == "build-up" for k in keys)
    return 0.0 if builds else 0.1


def stacked_residual(rig: Rig, records: Sequence[SeriesRecord], channels: Sequence[str],
                      sig: Mapping[str, float], overrides: Mapping[str, float],
                      start: float = 0.1) -> Arr:
    """Model − measurement / σ over ``start``-90 % of each measured phase, stacked
    (:func:`residual_parts`)."""
    return stacked(residual_parts(rig, records, channels, sig, overrides, start))[0]


def stacked(parts: Sequence[tuple[object, Arr]]) -> tuple[Arr, list[int]]:
    """The parts of :func:`residual_parts` as one vector (one zero when there are none)
    and each part's length: the samples of one record's phase segment and channel, the
    clusters of :func:`fit_cov`."""
    sizes = [p.size for _, p in parts]
    return (np.concatenate([p for _, p in parts]) if parts else np.zeros(1)), sizes


def residual_parts(rig: Rig, records: Sequence[SeriesRecord], channels: Sequence[str],
                   sig: Mapping[str, float], overrides: Mapping[str, float],
                   start: float = 0.1, tables: Sequence[pd.DataFrame] | None = None
                   ) -> list[tuple[str, Arr]]:
    """Model − measurement / σ over ``start``-90 % of each measured phase, per channel
    (one part per record, phase segment and channel); ``tables`` are the records'
    simulations with ``overrides`` where the caller has them already
    (:func:`~diagnostics.discrepancy.simulate.simulate_record`).

    A fixed set of samples (every 10th measured sample, time since phase start) whatever
    the simulated phase lasts, so the vector has one length for the optimiser; a model
    phase that ends earlier holds its last value there.  The working phase of a dwell
    record (:func:`~diagnostics.discrepancy.simulate.record_kind`) is compared as two
    segments, the motion and the dwell at the stop, each on the time since its own start
    (:func:`~diagnostics.discrepancy.simulate.phase_segments`): otherwise a shifted
    arrival at the stop, a step of the whole pump flow, would outweigh the effect.
    """
    parts: list[tuple[str, Arr]] = []
    stroke = float(rig.base.get("cylinder.stroke", 0.0))
    for i, r in enumerate(records):
        table = tables[i] if tables is not None else simulate_record(rig, r, overrides)
        phases = r.phase if r.phase is not None else np.full(r.t.size, "working")
        half = 0.5 * float(np.median(np.diff(r.t))) if r.t.size > 1 else 0.0
        dwell = record_kind(r, rig) == "dwell"
        for ph in ("working", "return"):
            sel = np.flatnonzero(phases == ph)
            tab = table[table["phase"] == ph]
            if sel.size < 20 or len(tab) < 3:
                continue
            if dwell and ph == "working":
                at = np.flatnonzero(despiked(r.channels["x"][sel]) >= stroke - AT_STOP)
                cut = int(at[0]) if at.size else sel.size
                measured = [s_ for s_ in (sel[:cut], sel[cut:]) if s_.size >= 20]
                model_parts = phase_segments(table, ph, stroke)
            else:
                measured = [sel]
                model_parts = [tab.assign(**{"t [s]": tab["t [s]"].to_numpy(dtype=float)
                                             - model_phase_start(table, ph)})]
            for k, seg in enumerate(measured):
                model_tab = model_parts[min(k, len(model_parts) - 1)]
                if k >= len(model_parts):      # the model never reached the stop: its end held
                    model_tab = model_tab.iloc[-1:].assign(**{"t [s]": 0.0})
                tm = r.t[seg] - phase_start(r.t, int(seg[0]))
                keep = (tm >= start * tm[-1]) & (tm <= 0.9 * tm[-1])
                idx = seg[keep][::10]
                at = tm[keep][::10] + model_origin(r, table, ph)
                res = {c: (v - r.channels[c][idx]) / sig[c]
                       for c, v in on_grid(model_tab, at, list(channels)).items()}
                parts.extend(_within_sample(model_tab, at, res, channels, sig, half).items())
    return parts


#: step of the model's time derivative in :func:`_within_sample` [s]
_RATE_STEP = 1e-4


def _within_sample(model_tab: pd.DataFrame, at: Arr, res: dict[str, Arr],
                   channels: Sequence[str], sig: Mapping[str, float], half: float
                   ) -> dict[str, Arr]:
    """A segment's residuals with its start placed within its sample: the model read
    δ later, δ within ± ``half`` a sample period [s], to first order (r + δ·ṁ/σ, δ the
    least-squares shift of all channels together).

    Where a logged switch fell between two samples is unknown to ± half a period
    (:func:`~diagnostics.discrepancy.simulate.phase_start`); left in the comparison, that
    offset of the whole phase is a misfit common to every sample of it, which a re-fit
    takes up with the parameters that move the speeds: on noise-free 1 kHz records of a
    piston worn to cc +20 %, the truth cost 176 (χ², the position 0.41 σ RMS off) and the
    wear re-fit ended at Rlp −2.2 % (cost 166), "significant"."""
    if half <= 0.0:
        return res
    ahead = on_grid(model_tab, at + _RATE_STEP, list(channels))
    behind = on_grid(model_tab, np.maximum(at - _RATE_STEP, 0.0), list(channels))
    step = at + _RATE_STEP - np.maximum(at - _RATE_STEP, 0.0)
    rate = {c: (ahead[c] - behind[c]) / step / sig[c] for c in channels}
    den = sum(float(rate[c] @ rate[c]) for c in channels)
    if den <= 0.0:
        return res
    delta = float(np.clip(-sum(float(rate[c] @ res[c]) for c in channels) / den, -half, half))
    return {c: res[c] + delta * rate[c] for c in channels}


def refit(doc: dict[str, Any], start: Mapping[str, float], records: Sequence[SeriesRecord],
           channels: Sequence[str], sig: Mapping[str, float], max_nfev: int
           ) -> tuple[dict[str, float], dict[str, float]]:
    """Output-error re-fit of the effect coefficients; returns (values, 1-σ errors)."""
    rig = Rig.from_spec(validate_rig_document(with_effects(doc, start)))
    keys = list(start)
    scale = np.array([abs(v) if v != 0 else 1.0 for v in start.values()])
    first = compare_from(keys)

    def fun(z: Arr, start: float = 0.1) -> Arr:
        ov = {k: float(zi * s) for k, zi, s in zip(keys, z, scale, strict=True)}
        try:
            parts = residual_parts(rig, records, channels, sig, ov, start)
        except (SimulationError, InputError):
            if start not in _n:  # the start itself cannot be simulated: say so
                raise
            return np.full(_n[start], 1e3)
        r, part_sizes = stacked(parts)
        if start == 0.1 and not sizes:
            sizes.extend(part_sizes)
        return r

    _n: dict[float, int] = {}
    sizes: list[int] = []  # samples per record, phase segment and channel
    r0 = fun(np.ones(len(keys)))
    _n[0.1] = r0.size
    lo, hi = parameter_bounds(keys)
    lb = lo / scale
    ub = hi / scale
    z0 = np.clip(np.ones(len(keys)), lb + 1e-12, ub - 1e-12)
    if first == 0.0 and len(keys) == 1:
        # the equation-error start of a build-up effect can be several times off, and the
        # cost is a narrow valley (the coefficient sets how the pressure rings up after a
        # switch: 5 % off costs as much as leaving the effect out): the valley is located
        # on a log grid over the build-up (0-90 %), then refined over 10-90 %, where the
        # record's phase start, known to a sample, no longer biases the fit
        grid = np.clip(np.geomspace(1.0 / GRID_SPAN, GRID_SPAN / 10.0, GRID_POINTS),
                       lb[0] + 1e-12, ub[0] - 1e-12)
        _n[0.0] = fun(np.ones(1), 0.0).size

        def build_cost(log_z: float) -> float:
            return float(np.sum(fun(np.array([math.exp(log_z)]), 0.0) ** 2))

        logs = np.log(np.append(grid, 1.0))
        costs = [build_cost(float(lz)) for lz in logs]
        k = int(np.argmin(costs))
        # then the bottom of the valley between the best grid point's neighbours (1 %)
        step = math.log(GRID_SPAN * GRID_SPAN / 10.0) / (GRID_POINTS - 1)
        best = minimize_scalar(build_cost, bounds=(logs[k] - step, logs[k] + step),
                               method="bounded", options={"xatol": 0.01})
        z_best = float(math.exp(best.x)) if best.fun < costs[k] else float(math.exp(logs[k]))
        # the build-up's cost is dominated by the first samples after the switch, where a
        # sample's misalignment outweighs the coefficient: its valley can sit 10-15 % off
        # the truth, and the compared part's (10-90 %) valley there is narrow (±5 %) and
        # the cost around it bumpy, out of reach of the local least-squares step (measured:
        # entrained air at 16 σ re-fitted 11 % low, P2 left at 3.1 σ).  So the compared
        # part's cost is scanned over the located valley's width and its best point
        # refined (a bounded search between its neighbours) before the least squares
        z_build = z_best
        logs10 = math.log(z_best) + np.linspace(-LOCAL_SPAN, LOCAL_SPAN, LOCAL_POINTS)

        def cost10(log_z: float) -> float:
            return float(np.sum(fun(np.array([math.exp(log_z)])) ** 2))

        costs10 = [cost10(float(lz)) for lz in logs10]
        j = int(np.argmin(costs10))
        h = logs10[1] - logs10[0]
        fine = minimize_scalar(cost10, bounds=(logs10[j] - h, logs10[j] + h), method="bounded",
                               options={"xatol": 0.002})
        z_best = float(math.exp(fine.x)) if fine.fun < costs10[j] else float(math.exp(logs10[j]))
        z0 = np.clip(np.array([z_best]), lb + 1e-12, ub - 1e-12)
    else:
        z_build = float("nan")
    # stop once the scaled coefficients move by < 0.1 % (far inside their interval) or the
    # cost by < 0.01 %: each evaluation re-simulates every training record
    sol = least_squares(fun, z0, bounds=(lb, ub), x_scale=1.0, diff_step=0.05,
                        max_nfev=max_nfev, xtol=1e-3, ftol=1e-4)
    if math.isfinite(z_build):
        # the compared part's cost is rippled on a 0.5 % scale (the samples against the
        # build-up's timing) around a narrow well at the truth: the least squares from the
        # build-up's valley can land in that well where the scan's ripple does not (air at
        # 8 σ: 0.5 % against 2.2 % off), so both are run and the lower cost kept
        other = least_squares(fun, np.clip(np.array([z_build]), lb + 1e-12, ub - 1e-12),
                              bounds=(lb, ub), x_scale=1.0, diff_step=0.05,
                              max_nfev=max_nfev, xtol=1e-3, ftol=1e-4)
        if other.cost < sol.cost:
            sol = other
    values = {k: float(z * s) for k, z, s in zip(keys, sol.x, scale, strict=True)}
    try:
        cov = fit_cov(sol.jac, sol.fun, sizes)
        err = {k: float(math.sqrt(max(cov[i, i], 0.0)) * scale[i]) for i, k in enumerate(keys)}
        if math.isfinite(z_build):
            # the noise alone understates a build-up coefficient's error: the build-up's
            # valley and the compared part's disagree (the first samples after a switch),
            # so half their distance is added in quadrature (measured: air at 8 σ re-fitted
            # 2.2 % low with a least-squares error of 0.06 %)
            (key,) = keys
            err[key] = math.hypot(err[key], 0.5 * abs(float(sol.x[0]) - z_build) * scale[0])
    except np.linalg.LinAlgError:
        err = dict.fromkeys(keys, float("nan"))
    return values, err


#: the solver's resolution in a re-fit's errors: the simulation's error at any compared
#: sample [σ] (:data:`~diagnostics.discrepancy.simulate.SOLVER`: ≤ 0.1 σ pressure and flow)
NUMERICAL = 0.1


def fit_cov(jac: Arr, resid: Arr, sizes: Sequence[int]) -> Arr:
    """Covariance of an output-error re-fit's parameters, each diagonal entry the widest of
    three (only the diagonal is used: the parameters' own errors).

    * (JᵀJ)⁻¹·s², every compared sample an independent reading;
    * the cluster-robust sandwich with each record's phase segment and channel one block
      (``sizes``, :func:`diagnostics.robust.cluster_cov`): coloured noise and a misfit a
      re-fit leaves are correlated over a phase (a hidden seal friction in AR(1) noise,
      φ = 0.9, was re-fitted with an interval that missed the truth);
    * the solver's resolution: the largest change of the parameter that an error of the
      simulation of at most ε σ at every compared sample could cause, ε·Σ_k |((JᵀJ)⁻¹Jᵀ)_ik|
      (ε = :data:`NUMERICAL`; the least-squares step of an error vector ±ε aligned with
      the parameter's own row of the pseudo-inverse).  Below it a re-fit cannot tell a
      change from the solver's own error: on a piston worn to cc +20 % alone the Jacobian
      alone stated Rlp and cv to ±0.003-0.04 %, and base drift read them "significant".
      (The change that moves the compared outputs by ε σ RMS, tried first, is far wider
      where a parameter's signature sits in a few samples: a wrong viscosity law at 8 σ,
      seen mostly in the hotter record, read t 1.4 by it, 6.4 by this.)

    Raises
    ------
    numpy.linalg.LinAlgError
        A singular JᵀJ (a parameter the records do not move).
    """
    J = np.asarray(jac, dtype=float)
    r = np.asarray(resid, dtype=float)
    inv = np.linalg.inv(J.T @ J)
    dof = max(r.size - J.shape[1], 1)
    cov = inv * float(r @ r) / dof
    if sum(sizes) == r.size and len(sizes) > 1:
        cov = np.maximum(cov, cluster_cov(J, r, sizes))
    bound = NUMERICAL * np.abs(inv @ J.T).sum(axis=1)
    np.fill_diagonal(cov, np.maximum(np.diag(cov), bound ** 2))
    return np.asarray(cov, dtype=float)


def output_cost(doc: dict[str, Any], values: Mapping[str, float],
                records: Sequence[SeriesRecord], channels: Sequence[str],
                sig: Mapping[str, float]) -> float:
    """Σ((model − measurement)/σ)² over 10-90 % of each phase of ``records`` [-] with the
    effect parameters ``values`` in the rig (:func:`stacked_residual`); ``inf`` if the
    solver fails."""
    try:
        rig = Rig.from_spec(validate_rig_document(with_effects(doc, values)))
        r = stacked_residual(rig, records, channels, sig, {})
    except (SimulationError, InputError):
        return math.inf
    return float(r @ r)


#: output-error BIC margin within which re-fitted alternatives count as not told apart
APART = 10.0


def tell_apart(doc: dict[str, Any], options: Sequence[Mapping[str, float]],
               records: Sequence[SeriesRecord], channels: Sequence[str],
               sig: Mapping[str, float], max_nfev: int,
               admissible: Callable[[Mapping[str, float]], bool] | None = None
               ) -> tuple[int, list[int], list[tuple[dict[str, float], dict[str, float]]]]:
    """Re-fit each alternative explanation in output-error form and compare them.

    The equation error sees one balance; re-simulation sees every logged channel, where
    explanations that share a balance's column part (a viscosity law changes every
    viscous element, a pressure-dependent piston clearance only the piston gap).  Each
    option (``effect.param`` → start value) is re-fitted (:func:`refit`) and scored by
    BIC = Σ((model − data)/σ)² + k·ln(n) over the compared samples.

    ``admissible`` (re-fitted values → bool) leaves out of ``best`` and ``group`` the
    options whose re-fitted values it refuses (all kept when it refuses every one).

    Returns
    -------
    best, group, fits
        Index of the lowest BIC; indices of the options within :data:`APART` of it, by
        rising BIC (the best first: the data cannot separate them); (values, 1-σ errors)
        per option.
    """
    fits = [refit(doc, start, records, channels, sig, max_nfev) for start in options]
    # the compared samples are fixed by the records (stacked_residual), whatever the model
    n = stacked_residual(Rig.from_spec(validate_rig_document(doc)), records, channels, sig,
                         {}).size
    bic = [output_cost(doc, values, records, channels, sig) + len(start) * math.log(max(n, 2))
           for (values, _), start in zip(fits, options, strict=True)]
    ok = [admissible is None or admissible(values) for values, _ in fits]
    if not any(ok):
        ok = [True] * len(fits)
    best = min((i for i in range(len(bic)) if ok[i]), key=bic.__getitem__)
    group = sorted((i for i, b in enumerate(bic) if ok[i] and b - bic[best] < APART),
                   key=bic.__getitem__)
    return best, group, fits
