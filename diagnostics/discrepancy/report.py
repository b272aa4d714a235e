"""The discrepancy report: charts (via :mod:`diagnostics.plots`) and a self-contained page.

Charts: the equation-error residual of the balance with the named effect (or the largest
residual) against time and against chamber/pump pressure, before and after the effect;
model vs measurement on the held-out record before and after (the effect, or the base
drift's re-fitted parameters).  The HTML page inlines the
SVGs (no scripts, no CDN, CSP-safe), so it opens offline.
"""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

import numpy as np

from diagnostics.discrepancy.drift import DRIFTING
from diagnostics.discrepancy.gap import aligned_residuals
from diagnostics.discrepancy.workflow import Discovery
from diagnostics.plots import Chart, Series, line_chart, render_png, render_svg, shown_unit

__all__ = ["DRIFT_INTERVALS", "charts", "html_page", "stored_line", "write_report"]

_PRESSURE = {"piston_force": "P1", "chamber_flow": "P1", "valve_flow": "P_valve_P",
             "pump_flow": "P_pump"}


def _thin(x: np.ndarray, n: int = 400) -> np.ndarray:
    step = max(1, x.size // n)
    return x[::step]


def charts(d: Discovery) -> dict[str, Chart]:
    """The report's charts by file stem."""
    out: dict[str, Chart] = {}
    sels = d.traces.get("selections", [])
    data = d.traces.get("data", [])
    signals = d.traces.get("signals")
    if sels and signals is not None:
        named_balances = {n.balance for n in d.named}
        pick = next((i for i, s in enumerate(sels) if s.balance in named_balances), None)
        if pick is None:
            pick = int(np.argmax([np.sqrt(np.mean(s.base_residual ** 2)) / s.full_scale
                                  for s in sels]))
        s, bd = sels[pick], data[pick]
        sub = signals.subset(bd.mask)
        t = np.arange(s.base_residual.size) / 1000.0
        # the charts in the units an engineer reads (bar, l/min, kN): a 0.2 bar gap drawn
        # in Pa under a 1e6 axis offset could not be seen (a discrepancy pass)
        k_res, res_unit = shown_unit(s.unit)
        series = [Series(_thin(t), _thin(k_res * s.base_residual), "base model (re-fitted)")]
        if s.chosen is not None:
            series.append(Series(_thin(t), _thin(k_res * s.residual), "with the named effect"))
        out["residual_vs_time"] = line_chart(
            f"Equation-error residual, {s.balance}", "sample time, records stacked [s]",
            f"residual [{res_unit}]", series)
        pname = _PRESSURE.get(s.balance, "P1")
        if pname in sub.values:
            p = sub.values[pname] / 1e5
            pts = [Series(_thin(p), _thin(k_res * s.base_residual), "base model",
                          kind="points")]
            if s.chosen is not None:
                pts.append(Series(_thin(p), _thin(k_res * s.residual), "with the named effect",
                                  kind="points"))
            out["residual_vs_pressure"] = line_chart(
                f"Residual vs {pname}, {s.balance}", f"{pname} [bar]",
                f"residual [{res_unit}]", pts)
    held = d.traces.get("held")
    before = d.traces.get("before")
    if held is not None and before is not None:
        chans = d.traces["channels"]
        after_rows = {(r.channel, r.region): r.rmse for r in d.gap_after}

        def gain(r: Any) -> float:
            if r.region != "steady":
                return -1.0
            if after_rows:
                return r.rmse / max(after_rows.get((r.channel, r.region), r.rmse), 1e-30)
            return r.rmse / max(float(np.std(held.channels[r.channel])), 1e-30)

        worst = max(d.gap_before, key=gain).channel if d.gap_before else chans[0]
        k_out, unit = shown_unit(held.units[worst])
        res_b = aligned_residuals(held, before, [worst])[worst]
        series = []

        def steady(tt: np.ndarray) -> np.ndarray:
            return (tt >= 0.1 * tt[-1]) & (tt <= 0.9 * tt[-1])

        for ph, (tt, e, meas) in res_b.items():
            k = steady(tt)
            series.append(Series(_thin(tt[k]), _thin(k_out * meas[k]), f"measured ({ph})",
                                 kind="points"))
            series.append(Series(_thin(tt[k]), _thin(k_out * (meas[k] + e[k])),
                                 f"base model ({ph})", dashed=True))
        after = d.traces.get("after")
        label = "with base drift" if d.verdict == "base drift" else "with effect"
        if after is not None:
            for ph, (tt, e, meas) in aligned_residuals(held, after, [worst])[worst].items():
                k = steady(tt)
                series.append(Series(_thin(tt[k]), _thin(k_out * (meas[k] + e[k])),
                                     f"{label} ({ph})"))
        out["model_vs_measurement"] = line_chart(
            f"Held-out record {held.name}: {worst} (steady part)", "time since phase start [s]",
            f"{worst} [{unit}]", series)
    return out


def _fmt(x: float) -> str:
    return "—" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.4g}"


#: What the base re-fit's intervals are, said where they are shown: from the Jacobian with
#: the samples taken as independent, so narrower than the spread of the estimates — a
#: Coulomb friction change (136 → 300 N) read Fu 297 [295, 299] and a "significant" Kf
#: +11 % that did not happen (a modelling engineer's pass).
DRIFT_INTERVALS = ("Intervals from the re-fit's Jacobian with the samples taken as "
                   "independent: narrower than the spread of the estimates, and parameters "
                   "that trade against each other (Fu and Kf) can show a change each that "
                   "only one of them made; read a 'significant' change as a lead, not a "
                   "measurement. 'n.s.' marks a change under 2.58 standard errors (two-sided "
                   "1 %, the level every effect's coefficient is held to), so a 95 % interval "
                   "can leave out the stored value of a change marked n.s.")


def stored_line(rig_id: int | None, version: int | None, new_version: int | None,
                not_stored: str | None) -> str:
    """What a run was checked against and what it stored, in one sentence ("" without a
    rig): a report page said neither, so a reader could not tell that version 2 had been
    stored, or why not (a modelling engineer's pass)."""
    if rig_id is None:
        return ""
    what = f"Checked against rig {rig_id} version {version}"
    if new_version is not None:
        return f"{what}; the named effect is stored as version {new_version} of the rig."
    if not_stored:
        return f"{what}; {not_stored}."
    return f"{what}; nothing was stored."


def html_page(d: Discovery, title: str = "hydrodiag discrepancy report", *,
              stored: str = "") -> str:
    """A self-contained HTML page of the report (inline SVG, no scripts, no external
    links); ``stored``: :func:`stored_line` of the run."""
    e = html.escape
    rep = d.to_dict()
    # an empty inline icon: a browser would otherwise ask the service for /favicon.ico
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{e(title)}"
             "</title><link rel='icon' href='data:,'></head><body>", f"<h1>{e(title)}</h1>",
             f"<p><strong>Verdict: {e(d.verdict)}</strong> — {e(d.message)}</p>",
             *([f"<p>{e(stored)}</p>"] if stored else []),
             f"<p>Training records: {e(', '.join(d.training))}; held out (edge of the operating "
             f"range): {e(', '.join(d.held_out) or 'none')}. Solver: {e(d.solver)}.</p>",
             *([f"<p>Random draws: {e(_draws(d.randomness))}.</p>"] if d.randomness else [])]
    if d.named:
        parts.append("<h2>Named effects</h2><table><tr><th>effect</th><th>physics</th>"
                     "<th>reference</th><th>signature</th><th>parameter</th><th>value</th>"
                     "<th>95 % interval</th><th>plausible range</th><th>t</th>"
                     "<th>bootstrap inclusion</th><th>competing</th><th>ambiguity group</th></tr>")
        for n in d.named:
            parts.append(
                f"<tr><td>{e(n.name)}</td><td>{e(n.explanation)}</td><td>{e(n.reference)}</td>"
                f"<td>{e(n.signature)}</td><td>{e(n.parameter)} [{e(n.unit)}]</td>"
                f"<td>{_fmt(n.value)}</td><td>{_fmt(n.interval[0])} … {_fmt(n.interval[1])}</td>"
                f"<td>{_fmt(n.plausible_range[0])} … {_fmt(n.plausible_range[1])}"
                f" ({'plausible' if n.plausible else 'NOT plausible'})</td>"
                f"<td>{_fmt(n.t)}</td><td>{_fmt(n.inclusion)}</td>"
                f"<td>{e(_groups(n.competing))}</td><td>{e(_groups(n.ambiguity))}</td></tr>")
        parts.append("</table>")
    if d.carried:
        # the effects the rig version already carries, checked on these data (a "no effect"
        # page said nothing of the Couette drag the data confirmed: a discrepancy pass)
        parts.append("<h2>Effects the rig already carries, checked on these data</h2><table>"
                     "<tr><th>effect</th><th>balance</th><th>stored coefficient</th>"
                     "<th>share the data hold (95 % interval)</th><th>|t| of the change</th>"
                     "<th>outcome</th></tr>")
        for check in d.carried:
            lo, hi = check.held_interval
            parts.append(f"<tr><td>{e(check.effect)}</td><td>{e(check.balance)}</td>"
                         f"<td>{_fmt(check.stored)}</td><td>{check.held:.2f} [{lo:.2f}, "
                         f"{hi:.2f}]</td><td>{_fmt(abs(check.t))}</td>"
                         f"<td>{e(check.outcome)}</td></tr>")
        parts.append("</table>")
    if d.base_drift is not None:
        accepted = d.base_drift.accepted
        state = ("they close the gap: base drift" if accepted
                 else "the wear the effect was named on" if d.named else "not accepted")
        how = "on the bench table's balance" if not d.base_drift.tables else "by re-simulation"
        parts.append(f"<h2>Base parameters re-fitted {how} ({state})"
                     "</h2>" + ("" if accepted else f"<p>{e(d.base_drift.reason)}</p>")
                     + f"<p>{e(DRIFT_INTERVALS)}</p>"
                     + "<table><tr><th>parameter</th><th>why it drifts</th><th>stored</th>"
                     "<th>re-fitted</th><th>change</th><th>95 % interval</th></tr>")
        for b in d.base_drift.parameters:
            lo, hi = b.interval or (math.nan, math.nan)
            # a clearance in µm, as the console and the CLI show it
            f, unit = shown_unit(b.unit, clearance=True) if b.unit == "m" else (1.0, b.unit)
            lo, hi = f * lo, f * hi
            parts.append(f"<tr><td>{e(b.parameter)} [{e(unit)}]</td><td>{e(b.why)}</td>"
                         f"<td>{_fmt(f * b.stored)}</td><td>{_fmt(f * b.value)}</td>"
                         f"<td>{100 * b.change:+.1f} %{'' if b.significant else ' (n.s.)'}"
                         f"</td><td>{_fmt(lo)} … {_fmt(hi)}</td></tr>")
        for k in d.base_drift.kept:
            parts.append(f"<tr><td>{e(k)}</td><td>{e(DRIFTING.get(k, ''))}</td><td colspan='4'>"
                         "kept as stored (not re-fitted)</td></tr>")
        parts.append("</table>")
    parts.append("<h2>Balances (equation error, base parameters re-fitted)</h2><table><tr>"
                 "<th>balance</th><th>chosen</th><th>ΔBIC</th><th>residual RMS</th>"
                 "<th>practical size</th><th>ambiguity groups</th>"
                 "<th>minimum detectable RMS per candidate</th>"
                 "<th>VIF per candidate (beside the base columns; reported, not filtered on)"
                 "</th></tr>")
    for b in rep["balances"]:
        # in the units an engineer reads (bar, l/min, kN), every size with its unit (the
        # practical size and the detectable RMS had none: a discrepancy pass)
        scale, unit = shown_unit(b["unit"])
        mds = ", ".join(f"{name}: {_fmt(scale * v)} {unit}" if v is not None
                        else f"{name}: not identifiable"
                        for name, v in b["minimum_detectable_rms"].items())
        vifs = ", ".join(f"{name}: {_fmt(v)}" if v is not None else f"{name}: ∞ (in the "
                         "base columns' span)" for name, v in b.get("vif", {}).items()) or "—"
        chosen = ", ".join(b["chosen"]) or "—"
        kept = b.get("picked_by_resimulation", b["chosen"])   # absent in older reports
        if kept != b["chosen"]:
            chosen += f" (re-simulation kept {', '.join(kept)})"
        parts.append(f"<tr><td>{e(b['balance'])}</td><td>{e(chosen)}</td>"
                     f"<td>{_fmt(b['bic_gain'])}</td><td>{_fmt(scale * b['residual_rms'])} "
                     f"[{e(unit)}]</td><td>{_fmt(scale * b['practical_size'])} [{e(unit)}]</td>"
                     f"<td>{e(_groups(b['ambiguity']))}</td><td>{e(mds)}</td>"
                     f"<td>{e(vifs)}</td></tr>")
    parts.append("</table>")
    parts.append("<h2>Held-out gap (model − measurement)</h2><p>Timing floor: the RMSE "
                 "between the model and itself read half a sample period later — a logged "
                 "switch is placed to within a sample, so after a step this much of a gap "
                 "is the logging's, not the model's.</p><table><tr><th>output</th>"
                 "<th>region</th><th>RMSE before</th><th>RMSE after</th><th>max before</th>"
                 "<th>max after</th><th>timing floor</th></tr>")
    after = {(r.channel, r.region): r for r in d.gap_after}
    for r in d.gap_before:
        a = after.get((r.channel, r.region))
        f, shown = shown_unit(r.unit)  # bar, l/min, mm (SI in the JSON)
        parts.append(f"<tr><td>{e(r.channel)} [{e(shown)}]</td><td>{e(r.region)}</td>"
                     f"<td>{_fmt(f * r.rmse)}</td><td>{_fmt(f * a.rmse) if a else '—'}</td>"
                     f"<td>{_fmt(f * r.max_abs)}</td>"
                     f"<td>{_fmt(f * a.max_abs) if a else '—'}</td>"
                     f"<td>{_fmt(f * r.timing_floor)}</td></tr>")
    if d.noise:
        # the σ every gap is judged against, and whether the records' noise is coloured
        # (a logger's filter): the whiteness below is then not expected of any model
        parts.append("</table><h2>Sensor noise (read from the records)</h2><table><tr>"
                     "<th>output</th><th>σ</th><th>sample-to-sample σ</th><th>AR(1) φ</th>"
                     "<th>noise</th></tr>")
        units = {r.channel: r.unit for r in d.gap_before}
        for c, noise in d.noise.items():
            f, shown = shown_unit(units[c]) if c in units else (1.0, "")
            label = f"{c} [{shown}]" if c in units else c
            parts.append(f"<tr><td>{e(label)}</td><td>{_fmt(f * noise.sigma)}</td>"
                         f"<td>{_fmt(f * noise.white)}</td>"
                         f"<td>{_fmt(noise.phi)}</td>"
                         f"<td>{'coloured' if noise.coloured else 'white'}</td></tr>")
    parts.append("</table><h2>Whiteness (Ljung-Box p, held-out, steady part)</h2><table>"
                 "<tr><th>output</th><th>before</th><th>after</th></tr>")
    for c, p in d.whiteness_before.items():
        parts.append(f"<tr><td>{e(c)}</td><td>{_fmt(p)}</td>"
                     f"<td>{_fmt(d.whiteness_after.get(c, float('nan')))}</td></tr>")
    parts.append("</table><h2>Plots</h2>")
    for chart in charts(d).values():
        parts.append(f"<figure>{render_svg(chart)}</figure>")
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(d: Discovery, path: str | Path, *, stored: str = "") -> dict[str, Any]:
    """Write the HTML page to ``path`` (``stored``: :func:`stored_line` of the run) and each
    chart as PNG and SVG beside it.

    Returns the written paths by kind.
    """
    p = Path(path)
    p.write_text(html_page(d, stored=stored), encoding="utf-8")
    written: dict[str, Any] = {"html": str(p), "png": [], "svg": []}
    for stem, chart in charts(d).items():
        png = p.with_name(f"{p.stem}_{stem}.png")
        svg = p.with_name(f"{p.stem}_{stem}.svg")
        png.write_bytes(render_png(chart))
        svg.write_text(render_svg(chart), encoding="utf-8")
        written["png"].append(str(png))
        written["svg"].append(str(svg))
    return written


def _draws(randomness: dict[str, int]) -> str:
    """``seed 0, 30 bootstrap replicates, 999 permutations``: what the report's random
    draws took (the same data and these give the same report)."""
    parts = [f"seed {randomness['seed']}"] if "seed" in randomness else []
    if "bootstrap" in randomness:
        parts.append(f"{randomness['bootstrap']} bootstrap replicates")
    if "permutations" in randomness:
        parts.append(f"{randomness['permutations']} permutations")
    return ", ".join(parts)


def _groups(groups: Any) -> str:
    """``[['base', 'couette_drag']]`` as a reader writes it: ``base + couette_drag``, groups
    separated by ``;``, ``—`` for none (the page printed Python's lists)."""
    if not groups:
        return "—"
    return "; ".join(" + ".join(str(x) for x in g) if isinstance(g, list | tuple) else str(g)
                     for g in groups)
