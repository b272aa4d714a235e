"""The discrepancy workflow on measured data: the V32HL56 map and the ZeMA rig (issues 8, 12).

**V32HL56 piston-pump map** (:func:`pump_discrepancy`).  Each displacement setting of
``data/real/pump-efficiency-V32HL56`` becomes a pump-bench table
(:func:`diagnostics.pump.piston.bench_frame`, the map's one unrecorded oil temperature
assumed as in :mod:`benchmarks.real_pump_map`) and goes through
:func:`diagnostics.discrepancy.steady.discover_steady` as a user's ``hydrodiag discover
bench.csv`` would, against a stored pump that paper 002's model can hold (:func:`stored_pump`):
the displacement by Toet's method (paper 000) and one laminar leak ``P/Rlp`` (eq. 5) fitted
to every row of the setting.  The workflow re-fits Rlp and Vp with any effect it names, so
the answer does not hang on this choice; the held-out rows are the top fifth of the
pressures (one temperature).

Then the question the workflow cannot ask of one table: is the loss ∝ Δp·ω it finds the
compression of the displaced oil (paper 000 eq. 6, the library entry, ∝ Vp), or something
else?  Across the five settings, the absolute coefficient ``a`` of Δp·ω in the flow loss
``ω·D − q = G·Δp + b·ω + a·Δp·ω`` [m³/(rad·Pa)] (:func:`cross_settings`) is fitted against
the displacement D [m³/rad]: paper 000 eq. 6's compressibility term ``Δp·D·ω/β`` with the
compressed volume per turn taken as the swept one plus a fixed dead volume V₀ [m³/rev] (our
extension, for a variable-displacement pump) gives ``a = D/β + V₀/(2π·β)`` (slope 1/β,
intercept V₀), and the share of ``a`` that appears in
the measured case-drain flow says how much of it is leakage (compression loses no oil to
the case).

**ZeMA rig** (:func:`zema_discrepancy`).  The working plateaus of the cycles
(:func:`diagnostics.real.profile.plateau_table`, settled flows) become bench tables
(:meth:`~diagnostics.real.profile.PlateauTable.bench`: plateau pressure, the oil
temperature of the cycle, the working flow FS1, the rig's stated 1500 rpm — the data record
no speed), one per pump-leakage class and, for the healthy pump, one per cooler state
(oil temperature 35-58 °C over all, a few degrees within a state); the labels choose the
rows only, nothing is fitted to them.  The stored rig is ``sim/rigs/zema.yaml``; held out:
the top fifth of the oil temperatures.  The pressures span only 140-166 bar, so a leak
∝ P/μ and one ∝ P²/μ differ by ±8 % there: the temperature does the separating.

Run: ``python -m benchmarks.real_discrepancy`` (also part of ``make real-data``;
``HYDRODIAG_LIGHT=1``: every 4th ZeMA cycle).  Prints tables and, as the last line, one
JSON object.
"""

from __future__ import annotations

import copy
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.real_pump_map import THETA
from diagnostics.discrepancy.pump_refit import robust_ols
from diagnostics.discrepancy.steady import discover_steady
from diagnostics.pump import bench_from_frame, derived_capacity_toet
from diagnostics.pump.data import BenchData
from diagnostics.pump.levels import cluster_levels
from diagnostics.pump.piston import PistonMap, bench_frame, read_efficiency_map
from diagnostics.real.profile import plateau_table
from diagnostics.real.relaxation import ZEMA_RELAXATION
from diagnostics.real.zema import find_shared, load_1hz, read_records, zema_root
from sim.rigs import load_rig_document, reference_rig_document

#: l/min per m³/s
LPM = 6e4
#: the ZeMA rig as hydrodiag describes it
ZEMA_RIG = Path(__file__).resolve().parents[1] / "sim" / "rigs" / "zema.yaml"
#: plateau flow settling time [s], found without labels by the ZeMA study
RELAXATION = ZEMA_RELAXATION


def stored_pump(bench: BenchData, source: str) -> dict[str, Any]:
    """The reference rig's document with its pump replaced by the bench's: Vp from Toet's
    derived capacity [m³/rev], Rlp from ω·Vp − q = Δp/Rlp by least squares over every row
    [Pa·s/m³]; each value's source says so."""
    D = derived_capacity_toet(bench).D
    dp = bench.p_out - bench.p_in
    g = float(np.sum((bench.omega * D - bench.q) * dp) / np.sum(dp * dp))
    doc = copy.deepcopy(reference_rig_document())
    pump = doc["components"]["pump"]["parameters"]
    pump["Vp"] = {"value": D * 2.0 * math.pi, "unit": "m^3/rev",
                  "source": f"{source}: Toet's derived capacity (paper 000)"}
    pump["Rlp"] = {"value": 1.0 / g, "unit": "Pa*s/m^3",
                   "source": f"{source}: laminar leak ω·Vp − q = Δp/Rlp, least squares"}
    doc["name"] = "v32hl56-bench"
    return doc


def cross_settings(data: PistonMap, idx: np.ndarray, n: int) -> dict[str, Any]:
    """``a`` (module docstring) per setting in the flow loss and the case-drain flow, and
    its line against D: 1/β, V₀ and the reduced χ² of the line."""
    D, a, se, drain = [], [], [], []
    for k in range(n):
        sub = data.subset(idx == k)
        d = derived_capacity_toet(bench_from_frame(bench_frame(sub, THETA))).D
        X = np.column_stack([sub.dp, sub.omega, sub.dp * sub.omega])
        c, s = robust_ols(X, sub.omega * d - sub.q)
        D.append(d)
        a.append(float(c[2]))
        se.append(float(s[2]))
        if sub.q_drain is not None:
            drain.append(float(robust_ols(X, sub.q_drain)[0][2]))
    Dv, av, w = np.array(D), np.array(a), 1.0 / np.array(se) ** 2
    A = np.column_stack([Dv, np.ones_like(Dv)])
    cov = np.linalg.inv(A.T @ (A * w[:, None]))
    slope, icpt = cov @ (A.T @ (w * av))
    chi2 = float(np.sum(w * (av - A @ np.array([slope, icpt])) ** 2))
    return {"D_m3_per_rad": D, "a_m3_per_rad_Pa": a, "a_stderr": se,
            "drain_share": [x / y for x, y in zip(drain, a, strict=True)] if drain else None,
            "beta_Pa": float(1.0 / slope), "beta_stderr_Pa": float(math.sqrt(cov[0, 0])
                                                                  / slope ** 2),
            "V0_cm3_per_rev": float(2.0 * math.pi * icpt / slope * 1e6),
            "line_chi2_per_dof": chi2 / max(len(D) - 2, 1)}


def pump_discrepancy() -> dict[str, Any]:
    """Print the table; return the figures."""
    path = find_shared() / "data" / "real" / "pump-efficiency-V32HL56" / "V32HL56-efficiency.csv"
    data = read_efficiency_map(path)
    idx, levels = cluster_levels(data.D, field="Displacement")
    print()
    print("discrepancy workflow on the V32HL56 map, one bench table per displacement setting "
          f"({THETA:.0f} °C assumed); held out: the top fifth of the pressures")
    print(f"{'V [cm³/rev]':>11s} {'verdict':>20s}  {'named (value, plausible range)':50s} "
          f"{'held-out RMSE l/min: stored → with effect':>42s}")
    rows = []
    for k in range(levels.size):
        sub = data.subset(idx == k)
        bench = bench_from_frame(bench_frame(sub, THETA))
        v = float(np.mean(sub.D)) * 2e6 * math.pi
        d = discover_steady(stored_pump(bench, f"V32HL56 map at {v:.1f} cm³/rev"), bench,
                            bootstrap=30, seed=0)
        named = _named(d)
        before = d.gap_before[0].rmse * LPM
        after = d.gap_after[0].rmse * LPM if d.gap_after else None
        text = ", ".join(f"{n['effect']} {n['value']:.3g} ({'in' if n['plausible'] else 'NOT in'}"
                         f" {n['plausible_range'][0]:.0g}…{n['plausible_range'][1]:.0g})"
                         for n in named) or "—"
        print(f"{v:11.1f} {d.verdict:>20s}  {text:50s} "
              f"{before:8.3f} → {after if after is not None else float('nan'):6.3f}")
        rows.append({"setting_cm3_per_rev": v, "rows": int(bench.q.size), "verdict": d.verdict,
                     "named": named, "held_out_rmse_before_lpm": before,
                     "held_out_rmse_after_lpm": after, "message": d.message})
    cross = cross_settings(data, idx, levels.size)
    print("the loss ∝ Δp·ω across the settings: a [m³/(rad·Pa)] = "
          + ", ".join(f"{x:.3g}" for x in cross["a_m3_per_rad_Pa"])
          + f"; a = D/β + V₀/(2πβ): β = {cross['beta_Pa'] / 1e9:.2f} ± "
          f"{cross['beta_stderr_Pa'] / 1e9:.2f} GPa, V₀ = {cross['V0_cm3_per_rev']:.0f} cm³/rev, "
          f"χ²/dof of the line {cross['line_chi2_per_dof']:.1f}")
    if cross["drain_share"] is not None:
        print("share of a in the case-drain flow: "
              + ", ".join(f"{x:.2f}" for x in cross["drain_share"]))
    return {"settings": rows, "cross_settings": cross,
            "named_everywhere": sorted(set.intersection(
                *[{n["effect"] for n in r["named"]} for r in rows])) if rows else [],
            "implausible_named": sum(not n["plausible"] for r in rows for n in r["named"])}


def _named(d: Any) -> list[dict[str, Any]]:
    return [{"effect": n.name, "value": n.value, "interval": list(n.interval),
             "plausible": n.plausible, "plausible_range": list(n.plausible_range), "t": n.t,
             "competing": n.competing} for n in d.named]


def zema_discrepancy(light: bool) -> dict[str, Any]:
    """Print the ZeMA table; return its figures (module docstring)."""
    root = zema_root()
    n_all = sum(1 for _ in (root / "profile.txt").open())
    cycles = list(range(1, n_all + 1, 4 if light else 1))
    data, labels = load_1hz(root, cycles, sensors=("PS1", "PS2", "FS1", "EPS1", "TS1"))
    table = plateau_table(read_records(data), relaxation=RELAXATION)
    doc = load_rig_document(ZEMA_RIG)
    speed = float(doc["components"]["pump"]["parameters"]["speed"]["value"]) * math.pi / 30
    leak, cooler = np.asarray(labels.leakage), np.asarray(labels.cooler)
    subsets = [(f"pump leakage class {int(c)}", leak == c) for c in np.unique(leak)]
    subsets += [(f"healthy pump, cooler {c:g} %", (leak == 0) & (cooler == c))
                for c in np.unique(cooler)]
    print()
    print(f"discrepancy workflow on the ZeMA plateaus ({len(cycles)} cycles"
          f"{', every 4th' if light else ''}; stored rig {ZEMA_RIG.name}; held out: the top "
          "fifth of the oil temperatures)")
    print(f"{'rows':28s} {'n':>5s} {'θ °C':>11s} {'verdict':>12s}  {'named (value, t)':34s} "
          f"{'held-out RMSE σ: stored → effect (pump alone)':>46s}")
    rows = []
    for name, mask in subsets:
        bench = table.bench(speed, mask, provenance=f"ZeMA plateaus, {name}")
        d = discover_steady(doc, bench, bootstrap=30, seed=0)
        sigma = float(d.traces["sigma"])
        named = _named(d)
        text = ", ".join(f"{n['effect']} {n['value']:.3g} (t {n['t']:.0f})" for n in named) or "—"
        before = d.gap_before[0].rmse * LPM
        after = d.gap_after[0].rmse * LPM if d.gap_after else None
        alone = d.traces["gap_alone"][0].rmse * LPM
        gap = (f"{before / (sigma * LPM):5.1f} → "
               + (f"{after / (sigma * LPM):4.1f}" if after is not None else "   —")
               + f" ({alone / (sigma * LPM):4.1f})")
        print(f"{name:28s} {bench.q.size:5d} {bench.theta.min():5.1f}-{bench.theta.max():4.1f} "
              f"{d.verdict:>12s}  {text:34s} {gap:>26s}")
        rows.append({"rows_of": name, "n": int(bench.q.size),
                     "theta_range": [float(bench.theta.min()), float(bench.theta.max())],
                     "verdict": d.verdict, "named": named, "sigma_lpm": sigma * LPM,
                     "held_out_rmse_before_lpm": before, "held_out_rmse_after_lpm": after,
                     "held_out_rmse_pump_alone_lpm": alone,
                     "message": d.message})
    return {"subsets": rows, "relaxation_s": RELAXATION,
            "named_in": {e: sum(any(n["effect"] == e for n in r["named"]) for r in rows)
                         for e in sorted({n["effect"] for r in rows for n in r["named"]})},
            "subset_count": len(rows)}


def main() -> None:
    """Print the tables and the JSON line."""
    light = os.environ.get("HYDRODIAG_LIGHT") == "1"
    print(json.dumps({"pump_map": pump_discrepancy(), "zema": zema_discrepancy(light)}))


if __name__ == "__main__":
    main()
