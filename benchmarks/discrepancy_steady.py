"""The steady half of the discrepancy study: pump-bench tables (part of
``make discrepancy-study``, run from :mod:`benchmarks.discrepancy_study`).

Test design (ISO 4409-style): pump speeds 50/75/100/125 % of the stated 1600 rpm ×
Δp 5/10/20/30/40/50 bar × 40/50/60 °C × 2 repeats = 144 points, flow σ 0.05 L/min and
pressure σ 0.05 bar (:func:`diagnostics.discrepancy.synthetic.synthesize_bench`); the
60 °C rows are held out.  Hidden effects: every registry entry of the ``pump_flow``
balance × sizes (peak flow difference over the grid, in σ of the flow meter) × seeds;
no-effect tables with Gaussian, reading-proportional and t₃ noise, with and without a
±20 % drift of the pump's Rlp and Vp.  Steady cases need no simulation (≈ 50 ms each), so
they run :data:`STEADY_FACTOR` × the seeds of the time-series cases.  ``RMSE ×`` is the
held-out RMSE of (model − noise-free truth) before/after naming (against the noisy flow
it could not exceed √(gap² + σ²)/σ).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from diagnostics.discrepancy.steady import discover_steady, predict_flow
from diagnostics.discrepancy.synthetic import NOISE, synthesize_bench
from sim.components.effects import EFFECTS
from sim.rigs import reference_rig, reference_rig_document

__all__ = ["STEADY_FACTOR", "steady_study"]

#: seeds of a steady cell per seed of a time-series cell
STEADY_FACTOR = 10
DRIFT = ("pump.Rlp", "pump.Vp")


def _peak(effect: str, value: float) -> float:
    """Largest |q with − q without| over the grid, noise-free [σ of the flow meter].

    Evaluated at 10⁻⁶ of ``value`` (the difference is linear in the strength) so that a
    strong reference strength cannot drive the synthetic flow negative.
    """
    rig = reference_rig()
    small = value * 1e-6
    a = synthesize_bench(rig, rng=np.random.default_rng(0), effects={effect: small},
                         sigma_q=0.0, sigma_p=0.0)
    b = synthesize_bench(rig, rng=np.random.default_rng(0), sigma_q=0.0, sigma_p=0.0)
    return float(np.max(np.abs(a.q - b.q))) / NOISE["Q_meter_B"] / 1e-6


def _truth_ratio(doc: dict[str, Any], d: Any, effect: str, strength: float) -> float:
    """Held-out (60 °C) RMSE of (model − noise-free truth) before/after naming: the stored
    rig, and the workflow's confirmation re-fit, fitted without the held-out rows
    (``d.traces["confirmation"]``: the named effect and the pump's slip and displacement on
    the training rows) — the augmented rig it returns is fitted on every row, so its figure
    there would not be out of sample.  Without that trace (a workflow that fitted the
    augmented rig on the training rows), the augmented rig, which carries the named effect
    already (its flow is part of :func:`~diagnostics.discrepancy.steady.predict_flow` since
    the stored effects are), so the effect is not passed again."""
    clean = synthesize_bench(reference_rig(), rng=np.random.default_rng(0),
                             effects={effect: strength}, sigma_q=0.0, sigma_p=0.0)
    held = clean.theta == clean.theta.max()
    before = predict_flow(doc, clean)[held] - clean.q[held]
    conf = d.traces.get("confirmation") or {}
    after = (predict_flow(doc, clean, conf["coefficients"], conf["base"]) if conf
             else predict_flow(d.rig_document, clean))[held] - clean.q[held]
    rb, ra = float(np.sqrt(np.mean(before ** 2))), float(np.sqrt(np.mean(after ** 2)))
    return rb / ra if ra > 0 else float("inf")


class _Named(Protocol):
    name: str
    ambiguity: Any
    competing: Any


class _Found(Protocol):
    @property
    def named(self) -> Sequence[_Named]: ...


def score(d: _Found, truth: str) -> str:
    """``exact`` (the true effect named alone), ``group`` (named or reported together with
    each named one: in its ambiguity group or as a competing explanation), ``wrong``
    (something named, the truth not among what was reported) or ``none``; the one rule of
    every discrepancy benchmark, for the cycles' ``Discovery`` and the tables' alike."""
    names = {n.name for n in d.named}
    if not names:
        return "none"
    if names == {truth}:
        return "exact"
    together = [{n.name} | {m for g in [*n.ambiguity, *n.competing] for m in g} for n in d.named]
    return "group" if all(truth in g for g in together) else "wrong"


def steady_study(seeds: int, sizes: tuple[float, ...], light: bool) -> dict[str, Any]:
    """Run the steady cases; print their table; return their figures."""
    n = seeds * STEADY_FACTOR
    rig, doc = reference_rig(), reference_rig_document()
    effects = [e.name for e in EFFECTS.values() if e.entry.balance == "pump_flow"]
    rows: list[dict[str, Any]] = []
    print(f"steady pump-bench tables: {n} seeds per cell")
    print(f"{'effect':28s} {'size':>5s} {'n':>4s} {'exact':>6s} {'group':>6s} {'wrong':>6s} "
          f"{'none':>5s} {'RMSE ×':>7s}")
    for effect in effects:
        e = EFFECTS[effect]
        ref = e.entry.plausible[1] / 10 if e.entry.plausible[1] > 0 else 1.0
        unit = ref / _peak(effect, ref)
        for size in sizes:
            counts = dict.fromkeys(("exact", "group", "wrong", "none"), 0)
            ratios: list[float] = []
            for s in range(n):
                bench = synthesize_bench(rig, rng=np.random.default_rng(7000 + s),
                                         effects={effect: size * unit})
                d = discover_steady(doc, bench, bootstrap=0 if light else 10, seed=s)
                outcome = score(d, effect)
                counts[outcome] += 1
                if outcome in ("exact", "group") and d.gap_after:
                    ratios.append(_truth_ratio(doc, d, effect, size * unit))
            row = {"effect": effect, "size_sigma": size, "strength": size * unit, "n": n,
                   **{k: v / n for k, v in counts.items()},
                   "median_rmse_ratio": float(np.median(ratios)) if ratios else None}
            rows.append(row)
            print(f"{effect:28s} {size:5.0f} {n:4d} {row['exact']:6.2f} {row['group']:6.2f} "
                  f"{row['wrong']:6.2f} {row['none']:5.2f} "
                  f"{row['median_rmse_ratio'] or float('nan'):7.2f}")
    n_null = max(1, round(n * 5 / 3))
    null_rows: list[dict[str, Any]] = []
    base = rig.values()
    for noise in ("gaussian", "proportional", "heavy"):
        for drift in (False, True):
            fd = 0
            names: set[str] = set()
            verdicts: dict[str, int] = {}
            for k in range(n_null):
                rng = np.random.default_rng(8000 + k)
                ov = {p: base[p] * rng.uniform(0.8, 1.2) for p in DRIFT} if drift else None
                bench = synthesize_bench(rig, rng=rng, noise=noise, overrides=ov)
                d = discover_steady(doc, bench, bootstrap=0)
                fd += bool(d.named)
                names |= {m.name for m in d.named}
                verdicts[d.verdict] = verdicts.get(d.verdict, 0) + 1
            null_rows.append({"noise": noise, "drift": drift, "n": n_null,
                              "false_discoveries": fd, "named": sorted(names),
                              "verdicts": verdicts})
            print(f"steady no effect, {noise:12s} noise, drift "
                  f"{'±20 %' if drift else 'none  '}: {fd}/{n_null} false discoveries; "
                  + ", ".join(f"{v} {c}" for v, c in sorted(verdicts.items())))
    total = sum(r["n"] for r in null_rows)
    fd_total = sum(r["false_discoveries"] for r in null_rows)

    def rate(size: float, key: str) -> float | None:
        sel = [r[key] for r in rows if r["size_sigma"] == size]
        return float(np.mean(sel)) if sel else None

    return {"steady_effects": effects, "steady_seeds_per_cell": n,
            "steady_exact_rate_by_size": {str(s): rate(s, "exact") for s in sizes},
            "steady_group_rate_by_size": {str(s): rate(s, "group") for s in sizes},
            "steady_wrong_rate_by_size": {str(s): rate(s, "wrong") for s in sizes},
            "steady_no_effect_cases": total, "steady_false_discoveries": fd_total,
            "false_discovery_rate_steady": fd_total / total if total else None,
            "steady_rows": rows, "steady_no_effect": null_rows}
