"""The V32HL56 piston-pump map (issue 12): capacity, loss families, paper 001's best subset.

Reads ``data/real/pump-efficiency-V32HL56/V32HL56-efficiency.csv`` of the shared data
(``HYDRODIAG_SHARED``, else ``../shared``, else ``/work/shared``).  Per displacement setting:

* the derived capacity (intercept, Toet, Vimax; one temperature, assumed) against the
  file's displacement;
* the sign-checked piston loss family (:mod:`diagnostics.pump.piston`) with one speed left
  out at a time, next to a plain quadratic in (Δp, n) on the same split, with the flow loss
  fitted to Qth − QOut and to the measured case-drain flow;
* where the held-out error comes from: S over the interior speeds only (no extrapolation
  to the lowest or highest speed), and the scatter floor (rms residual of a cubic in Δp
  fitted to each speed on its own, in-sample), below which no model of (Δp, n) can go;
* whether the model's held-out S differs from the quadratic's beyond chance: a paired block
  bootstrap over the speed levels (:mod:`diagnostics.pump.compare`); the target
  "no worse than the quadratic" is still scored as the plain comparison of the two S;
* where the quadratic wins: whether it is itself a sign-valid member of the loss family
  (:func:`~diagnostics.pump.compare.quadratic_in_family`), and speed by speed the terms AIC
  chose in that fold against the quadratic's, with both held-out S
  (:func:`~diagnostics.pump.compare.fold_s`);
* paper 001's best subset (Table 1 terms, AIC, VIF ≤ 10, sign checks;
  :mod:`diagnostics.pump.map_subset`): in-sample S and R² as paper 001 reports them, and
  with one speed left out.

S is printed in % of the setting's largest flow (torque) and, as paper 001 does, in % of
the pump's full flow (torque): the largest of the whole map.  The map is small, so
``HYDRODIAG_LIGHT=1`` changes nothing here.  Run: ``python -m benchmarks.real_pump_map``
(also part of ``make real-data``).  Last line: JSON.
"""

from __future__ import annotations

import json

import numpy as np

from diagnostics.pump import (
    bench_from_frame,
    derived_capacity_intercept,
    derived_capacity_toet,
    derived_capacity_vimax,
)
from diagnostics.pump.compare import (
    QUADRATIC_TERMS,
    fold_s,
    quadratic_in_family,
    s_difference,
)
from diagnostics.pump.levels import cluster_levels
from diagnostics.pump.map_subset import subset_held_out
from diagnostics.pump.piston import (
    FLOW_LOSS_TERMS,
    TORQUE_LOSS_TERMS,
    HeldOut,
    PistonMap,
    bench_frame,
    held_out_speed,
    read_efficiency_map,
)
from diagnostics.real.zema import find_shared
from sim.errors import InputError

#: Oil temperature assumed for the map, which records none [°C].
THETA = 50.0


def _capacities(sub: PistonMap, D: float) -> dict[str, float]:
    bench = bench_from_frame(bench_frame(sub, THETA))
    caps = {}
    for name, fn in (("toet", derived_capacity_toet), ("intercept", derived_capacity_intercept),
                     ("vimax", derived_capacity_vimax)):
        try:
            caps[name] = 100.0 * (fn(bench).D / D - 1.0)
        except InputError as exc:
            caps[name] = float("nan")
            print(f"  {name} capacity refused at {D * 2e6 * np.pi:.1f} cm³/rev: {exc}")
    return caps


def _inner_and_floor(sub: PistonMap, h: HeldOut) -> tuple[float, float, float, float]:
    """Held-out S over the interior speeds only, and the scatter floor (rms residual of a
    cubic in Δp fitted to each speed alone), flow and torque [% of the setting's max]."""
    w_idx, w_lev = cluster_levels(sub.omega, field="Speed")
    inner = (w_idx > 0) & (w_idx < w_lev.size - 1)
    fi = 100.0 * float(np.sqrt(np.mean((sub.q - h.flow_pred)[inner] ** 2))) / h.flow_full
    ti = 100.0 * float(np.sqrt(np.mean((sub.torque - h.torque_pred)[inner] ** 2))) / h.torque_full
    sse = np.zeros(2)  # flow, torque
    dof = 0
    for j in range(w_lev.size):
        m = w_idx == j
        x = np.vander(sub.dp[m] / 1e7, 4)  # cubic in Δp [10 MPa]
        for i, y in enumerate((sub.q[m], sub.torque[m])):
            r = y - x @ np.linalg.lstsq(x, y, rcond=None)[0]
            sse[i] += float(r @ r)
        dof += int(m.sum()) - 4
    sq, st = float(sse[0]), float(sse[1])
    return (fi, ti, 100.0 * float(np.sqrt(sq / dof)) / h.flow_full,
            100.0 * float(np.sqrt(st / dof)) / h.torque_full)


def _signs_ok(h: HeldOut) -> bool:
    """Every coefficient of the chosen flow and torque models has its term's sign."""
    ok = True
    for fit, library in ((h.flow, FLOW_LOSS_TERMS), (h.torque, TORQUE_LOSS_TERMS)):
        signs = {t.name: t.sign for t in library}
        ok &= all(signs[n] == 0 or c >= 0 for n, c in zip(fit.terms, fit.coef, strict=True))
    return bool(ok)


def _why_quadratic(sub: PistonMap, D: float, h: HeldOut) -> dict[str, object]:
    """Print and return, per response, the quadratic's membership of the family and, where
    it wins, the fold-by-fold terms and S (% of the setting's max)."""
    mem = quadratic_in_family(sub, D)
    _, w_lev = cluster_levels(sub.omega, field="Speed")
    out: dict[str, object] = {}
    for name, y, pm, pq, full, terms, member, coef in (
            ("flow", sub.q, h.flow_pred, h.flow_pred_quadratic, h.flow_full,
             h.fold_flow_terms, mem.flow_member, mem.flow_coef),
            ("torque", sub.torque, h.torque_pred, h.torque_pred_quadratic, h.torque_full,
             h.fold_torque_terms, mem.torque_member, mem.torque_coef)):
        sm, sq = fold_s(y, pm, pq, sub.omega, full)
        same = [set(t) == QUADRATIC_TERMS for t in terms]
        out[name] = {"quadratic_is_sign_valid_member": member, "quadratic_coef": coef,
                     "folds_choosing_quadratic_terms": int(sum(same)),
                     "fold_S_model_pct": sm.tolist(), "fold_S_quadratic_pct": sq.tolist(),
                     "fold_terms": [list(t) for t in terms]}
        s_m = float(np.sqrt(np.mean((y - pm) ** 2)))
        s_q = float(np.sqrt(np.mean((y - pq) ** 2)))
        if s_m <= s_q:
            continue
        print(f"{'':11s} {name}: the quadratic wins; it is "
              f"{'a sign-valid member of the family' if member else 'NOT sign-valid (a family sign broken)'}"
              f"; folds where AIC chose its six terms: {sum(same)} of {len(same)}")
        for k, (t, a, b) in enumerate(zip(terms, sm, sq, strict=True)):
            drop = sorted(QUADRATIC_TERMS - set(t))
            add = sorted(set(t) - QUADRATIC_TERMS)
            print(f"{'':13s} {w_lev[k] * 60.0 / (2.0 * np.pi):5.0f} rpm left out: S model "
                  f"{a:.3f} quadratic {b:.3f} ({a - b:+.3f}); vs the quadratic's terms: "
                  f"dropped {', '.join(drop) or '-'}; added {', '.join(add) or '-'}")
    return out


def _marks(row: dict[str, object]) -> str:
    t = row["targets"]
    assert isinstance(t, dict)
    return " ".join(f"{k}:{'yes' if v else 'MISS'}" for k, v in t.items())


def pump_map() -> dict[str, object]:
    """Print the map's tables; return its figures."""
    path = find_shared() / "data" / "real" / "pump-efficiency-V32HL56" / "V32HL56-efficiency.csv"
    data = read_efficiency_map(path)
    idx, levels = cluster_levels(data.D, field="Displacement")
    q_pump, t_pump = float(np.max(data.q)), float(np.max(data.torque))
    print()
    print(f"V32HL56 piston-pump map: {len(data)} points, {levels.size} displacement settings, "
          f"one unrecorded temperature ({THETA:.0f} °C assumed; enters only the scale of "
          "paper 001's μ terms)")
    print("piston loss family, one speed left out at a time; S in % of the setting's largest "
          "flow (torque) [and of the pump's full flow (torque)]")
    print(f"{'V [cm³/rev]':>11s} {'Toet %':>7s} {'icpt %':>7s} {'Vimax %':>7s} {'speeds':>6s} "
          f"{'flow S%':>15s} {'quad S%':>15s} {'drain S%':>8s} {'torque S%':>15s} "
          f"{'quad S%':>15s}")
    rows: list[dict[str, object]] = []
    for k in range(levels.size):
        sub = data.subset(idx == k)
        D = float(np.mean(sub.D))
        v = D * 2.0 * np.pi * 1e6
        caps = _capacities(sub, D)
        h = held_out_speed(sub, D)
        hd = held_out_speed(sub, D, target="drain")
        fq, ft = h.flow_full / q_pump, h.torque_full / t_pump
        print(f"{v:11.1f} {caps['toet']:+7.2f} {caps['intercept']:+7.2f} "
              f"{caps['vimax']:+7.2f} {h.speeds:6d} "
              f"{h.flow_S:6.3f} [{h.flow_S * fq:6.3f}] "
              f"{h.flow_S_quadratic:6.3f} [{h.flow_S_quadratic * fq:6.3f}] {hd.flow_S:8.3f} "
              f"{h.torque_S:6.3f} [{h.torque_S * ft:6.3f}] "
              f"{h.torque_S_quadratic:6.3f} [{h.torque_S_quadratic * ft:6.3f}]")
        fi, ti, ff, tf = _inner_and_floor(sub, h)
        print(f"{'':11s} interior speeds only: flow S {fi:.3f} %, torque S {ti:.3f} %; "
              f"scatter floor: flow {ff:.3f} %, torque {tf:.3f} %")
        print(f"{'':11s} flow loss: {' + '.join(h.flow_terms)};  torque loss: "
              f"{' + '.join(h.torque_terms)}")
        dq = s_difference(sub.q, h.flow_pred, h.flow_pred_quadratic, sub.omega, h.flow_full)
        dt = s_difference(sub.torque, h.torque_pred, h.torque_pred_quadratic, sub.omega,
                          h.torque_full)
        print(f"{'':11s} S(model) − S(quadratic), 95 % paired bootstrap over the {dq.blocks} "
              f"speeds: flow {dq.difference:+.3f} [{dq.low:+.3f}, {dq.high:+.3f}] %, torque "
              f"{dt.difference:+.3f} [{dt.low:+.3f}, {dt.high:+.3f}] %")
        why = _why_quadratic(sub, D, h)
        sf = subset_held_out(sub, D, response="flow", theta=THETA)
        st = subset_held_out(sub, D, response="torque", theta=THETA)
        rows.append({
            "displacement_cm3_rev": v, "capacity_pct_vs_file": caps, "speeds": h.speeds,
            "flow_S_pct": h.flow_S, "flow_S_pct_of_full_flow": h.flow_S * fq,
            "flow_R2": h.flow_R2, "flow_S_quadratic_pct": h.flow_S_quadratic,
            "flow_S_quadratic_pct_of_full_flow": h.flow_S_quadratic * fq,
            "flow_R2_quadratic": h.flow_R2_quadratic, "flow_S_drain_target_pct": hd.flow_S,
            "torque_S_pct": h.torque_S, "torque_S_pct_of_full_torque": h.torque_S * ft,
            "torque_R2": h.torque_R2, "torque_S_quadratic_pct": h.torque_S_quadratic,
            "torque_S_quadratic_pct_of_full_torque": h.torque_S_quadratic * ft,
            "flow_terms": list(h.flow_terms), "torque_terms": list(h.torque_terms),
            "flow_S_interior_speeds_pct": fi, "torque_S_interior_speeds_pct": ti,
            "flow_scatter_floor_pct": ff, "torque_scatter_floor_pct": tf,
            "quadratic_vs_family": why,
            "S_minus_quadratic_95pct": {
                "flow": [dq.difference, dq.low, dq.high],
                "torque": [dt.difference, dt.low, dt.high]},
            "targets": {
                "flow_S_le_0.3": h.flow_S <= 0.3,
                "flow_S_le_0.3_of_full_flow": h.flow_S * fq <= 0.3,
                "flow_no_worse_than_quadratic": h.flow_S <= h.flow_S_quadratic,
                "torque_S_le_0.3": h.torque_S <= 0.3,
                "torque_S_le_0.3_of_full_torque": h.torque_S * ft <= 0.3,
                "torque_no_worse_than_quadratic": h.torque_S <= h.torque_S_quadratic,
                "flow_not_significantly_worse_than_quadratic": dq.low <= 0.0,
                "torque_not_significantly_worse_than_quadratic": dt.low <= 0.0,
                "signs_physical": _signs_ok(h)},
            "paper001_subset": {
                r.response: {"terms": list(r.model.terms),
                             "coef": [float(c) for c in r.model.coef],
                             "max_vif": r.model.max_vif, "S_pct": r.S_pct, "R2": r.r2,
                             "held_out_S_pct": r.held_out_S_pct,
                             "held_out_R2": r.held_out_r2,
                             "not_identifiable": list(r.not_identifiable)}
                for r in (sf, st)},
        })
    print()
    print("targets per setting (S in % of the setting's max; 'of_full': % of the pump's max; "
          "the quadratic on the same split):")
    for row in rows:
        print(f"{row['displacement_cm3_rev']:11.1f}  {_marks(row)}")
    print()
    print("paper 001 best subset (Table 1 terms, AIC, VIF ≤ 10, sign checks), per setting: "
          "in-sample S, R² (as paper 001) | one speed left out; S in % of the setting's max")
    print(f"{'V [cm³/rev]':>11s} {'flow S%':>8s} {'R²':>8s} {'held S%':>8s} {'held R²':>8s} "
          f"{'VIF':>5s}  {'torque S%':>9s} {'R²':>8s} {'held S%':>8s} {'held R²':>8s}  terms")
    for row in rows:
        p = row["paper001_subset"]
        assert isinstance(p, dict)
        f, t = p["flow"], p["torque"]
        comp = dict(zip(f["terms"], f["coef"], strict=True)).get("comp_zarotti")
        print(f"{row['displacement_cm3_rev']:11.1f} {f['S_pct']:8.3f} {f['R2']:8.5f} "
              f"{f['held_out_S_pct']:8.3f} {f['held_out_R2']:8.5f} {f['max_vif']:5.2f}  "
              f"{t['S_pct']:9.3f} {t['R2']:8.5f} {t['held_out_S_pct']:8.3f} "
              f"{t['held_out_R2']:8.5f}  {'+'.join(f['terms'])} | {'+'.join(t['terms'])}"
              + (f"  (compressibility coef {comp:.2f}, physics −1)" if comp is not None
                 else ""))
    print("paper 001 (its own axial piston pump, all settings in one model, in-sample): flow "
          "S 0.426 l/min of ~100 l/min (0.43 %), R² 0.9997; LHS plan 0.256 l/min")

    def every(key: str, other: str | None = None, limit: float | None = None) -> bool:
        return all((limit is None or float(r[key]) <= limit)  # type: ignore[arg-type]
                   and (other is None or float(r[key]) <= float(r[other]))  # type: ignore[arg-type]
                   for r in rows)

    return {"settings": rows,
            "targets": {
                "flow_S_le_0.3_all": every("flow_S_pct", limit=0.3),
                "flow_S_le_0.3_of_full_flow_all": every("flow_S_pct_of_full_flow", limit=0.3),
                "flow_no_worse_than_quadratic_all": every("flow_S_pct", "flow_S_quadratic_pct"),
                "torque_S_le_0.3_all": every("torque_S_pct", limit=0.3),
                "torque_S_le_0.3_of_full_torque_all": every("torque_S_pct_of_full_torque",
                                                            limit=0.3),
                "torque_no_worse_than_quadratic_all": every("torque_S_pct",
                                                            "torque_S_quadratic_pct"),
                "signs_physical_all": all(bool(r["targets"]["signs_physical"])  # type: ignore[index]
                                          for r in rows)}}


def main() -> None:
    """Run the map study alone; print its tables and the JSON line."""
    print(json.dumps({"study": "real_pump_map", "pump_map": pump_map()}))


if __name__ == "__main__":
    main()
