"""Charts of the console's pages and the CLI's reports, built from stored results.

Every function returns :class:`diagnostics.plots.Chart` values (or ``None`` where there is
nothing to draw); pages render them with :func:`diagnostics.plots.render_svg`, reports with
the same function or :func:`diagnostics.plots.render_png`, so both show the same plots.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from app.schemas.pump_leak import PumpLeakResponse
from app.services.pump_leak import segments
from app.services.trends import UNLIKELY, ComponentTrendOut
from diagnostics.plots import (
    MUTED,
    PALETTE,
    SHOWN_UNITS,
    Bar,
    Chart,
    Series,
    bar_chart,
    line_chart,
    shown_unit,
)
from diagnostics.timeseries import SeriesRecord

__all__ = [
    "SEVERITY_BANDS",
    "calibration_chart",
    "estimate_charts",
    "leak_chart",
    "predicted_for",
    "probability_chart",
    "reading_chart",
    "record_index",
    "series_charts",
    "sigma_for",
    "simulation_charts",
    "surface_chart",
    "trend_chart",
]

#: Severity bands of a clearance, :func:`diagnostics.ranking.severity`: laminar leakage
#: multiples 1.33, 2.2 and 4.1 (leakage ∝ c³), as clearance multiples c/c₀ [1].
SEVERITY_BANDS = (("mild", 1.33 ** (1 / 3)), ("moderate", 2.2 ** (1 / 3)),
                  ("severe", 4.1 ** (1 / 3)))

#: Colour of each severity band of :func:`diagnostics.ranking.severity`: the plotting
#: module's palette, each 3:1 or more against the chart (the severity is also said in
#: words beside the bar)
_SEVERITY_COLOURS = {"nominal": PALETTE[2], "mild": PALETTE[5], "moderate": PALETTE[4],
                     "severe": PALETTE[1]}


def probability_chart(result: Mapping[str, Any], *, top: int = 8) -> Chart:
    """Posterior probability [1] of each hypothesis of a diagnosis, largest first; where
    nothing explains the readings, their relative fit, titled as such (a full bar under
    "unexplained (p = 0)" read as the answer: a plant operator's pass), in grey."""
    fits = sorted(result.get("hypotheses", []), key=lambda f: -(f.get("probability") or 0.0))
    explained = result.get("explained", True) is not False
    bars = [Bar(f["name"], float(f.get("probability") or 0.0),
                color="#0072B2" if explained and f.get("observable", True) else MUTED)
            for f in fits[:top]]
    if not explained:
        return bar_chart("Relative fit only: no hypothesis explains the readings",
                         "share of the fit among the hypotheses [1]", bars)
    return bar_chart("Hypothesis probabilities", "probability [1]", bars)


def record_index(result: Mapping[str, Any]) -> int:
    """Which of a joint diagnosis's records the stored result belongs to (its
    ``record_index``; 0 for a single record and for results stored before it was kept)."""
    index = result.get("record_index")
    return index if isinstance(index, int) and index >= 0 else 0


def _of_record(per_record: Any, index: int) -> dict[str, Any]:
    """Entry ``index`` of a per-record list of a stored result (empty if none)."""
    items = per_record or []
    return dict(items[index]) if index < len(items) and items[index] else {}


def predicted_for(fit: Mapping[str, Any], index: int) -> dict[str, Any]:
    """A hypothesis's predictions of record ``index`` of the diagnosis (empty if none)."""
    return _of_record(fit.get("predicted"), index)


def sigma_for(result: Mapping[str, Any], index: int) -> dict[str, Any]:
    """The σ the diagnosis weighed each reading of record ``index`` by (``reading_sigma``;
    empty for results stored before it was kept) [SI unit of the reading]."""
    return _of_record(result.get("reading_sigma"), index)


def reading_chart(result: Mapping[str, Any], measured: Mapping[str, tuple[float, float]],
                  *, leading: int = 3) -> Chart | None:
    """Measured readings with their 95 % interval against each leading hypothesis' prediction.

    Each reading is drawn relative to its measured value, ``(y / measured − 1)`` [1], so
    pressures, flows and speeds share one axis: the measurement sits at 0 with its
    instrument's interval ±1.96·u/|measured| and, left of it in grey, ±1.96·σ/|measured|
    with σ the standard uncertainty the diagnosis weighed it by (``reading_sigma``: the
    instrument's, the model's and the stated load's and temperature's, which moves every
    reading of the record at once), each hypothesis' prediction beside it.

    Parameters
    ----------
    result
        The stored diagnosis result (``hypotheses`` with ``predicted``).
    measured
        Reading name → (value, standard uncertainty u) [SI unit of the reading].
    leading
        Number of most probable hypotheses drawn.
    """
    names = [n for n, (v, _) in measured.items() if v != 0.0 and math.isfinite(v)]
    if not names:
        return None
    x = np.arange(len(names), dtype=float)
    half = np.array([1.959963984540054 * measured[n][1] / abs(measured[n][0]) for n in names])
    series = [Series(x, np.zeros_like(x), "measured, instrument (95 %)", kind="errorbars",
                     low=-half, high=half, color="#000000")]
    index = record_index(result)
    sigma = sigma_for(result, index)
    weighed = np.array([1.959963984540054 * float(sigma[n]) / abs(measured[n][0])
                        if sigma.get(n) is not None else np.nan for n in names])
    keep = np.isfinite(weighed)
    if keep.any():
        series.append(Series(x[keep] - 0.12, np.zeros(int(keep.sum())),
                             "as the diagnosis weighs it (95 %; load, temperature, model)",
                             kind="errorbars", low=-weighed[keep], high=weighed[keep],
                             color="#777777"))
    fits = sorted(result.get("hypotheses", []), key=lambda f: -(f.get("probability") or 0.0))
    for i, fit in enumerate(fits[:leading]):
        predicted = predicted_for(fit, index)
        y = np.array([(predicted.get(n) if predicted.get(n) is not None else np.nan)
                      for n in names], dtype=float)
        rel = y / np.array([measured[n][0] for n in names]) - 1.0
        keep = np.isfinite(rel)
        if keep.any():
            series.append(Series(x[keep] + 0.12 * (i + 1), rel[keep],
                                 f"{fit['name']} (p = {fit.get('probability') or 0:.2g})",
                                 kind="points"))
    return line_chart("Measured vs predicted, relative to the measurement", "reading",
                      "predicted / measured − 1 [1]", series, hlines=[(0.0, "")],
                      xticks=names)


def estimate_charts(result: Mapping[str, Any]) -> list[Chart]:
    """Component estimates with their 95 % intervals against nominal and severity bands.

    Clearances in multiples of their nominal value [1] in one chart (c/c₀; the laminar
    leakage grows as its cube), the severity bands of :data:`SEVERITY_BANDS` as dotted
    lines; a quantity without a nominal value (the pump's slip coefficient) in its own unit.
    """
    nominal = _nominals(result)
    relative: list[Bar] = []
    charts = []
    for component, e in (result.get("estimates") or {}).items():
        value, low, high = e.get("value"), e.get("low"), e.get("high")
        if value is None or low is None or high is None:
            continue
        c0 = nominal.get(e.get("quantity"))
        label = f"{component} {e['quantity']}"
        if c0:
            relative.append(Bar(label, value / c0, low / c0, high / c0,
                                color=_SEVERITY_COLOURS.get(_band(value / c0), "#0072B2")))
        else:
            charts.append(bar_chart(f"{component}: {e['quantity']} (95 % interval)",
                                    f"{e['quantity']} [{e.get('unit', '')}]",
                                    [Bar(label, value, low, high)]))
    if relative:
        bands = ", ".join(f"{name} ×{m:.2f}" for name, m in SEVERITY_BANDS)
        chart = bar_chart("Estimates / nominal (95 % intervals)",
                          f"estimate / nominal [1]   (dotted: nominal ×1, {bands})", relative,
                          reference=[(1.0, "")] + [(m, "") for _, m in SEVERITY_BANDS],
                          size=(7.0, 1.4 + 0.45 * len(relative)))
        charts.insert(0, chart)
    return charts


def _band(multiple: float) -> str:
    name = "nominal"
    for band, start in SEVERITY_BANDS:
        if multiple >= start:
            name = band
    return name


def _nominals(result: Mapping[str, Any]) -> dict[str, float]:
    """Nominal value of each fitted quantity, from the hypotheses' parameters."""
    out: dict[str, float] = {}
    for fit in result.get("hypotheses", []):
        for p in fit.get("parameters", []):
            if p.get("nominal"):
                out.setdefault(p["name"], float(p["nominal"]))
    return out


def trend_chart(trend: ComponentTrendOut) -> Chart:
    """A component's estimates over time [day] with intervals, Theil–Sen line, threshold.

    An estimate whose diagnosis gave the component a probability below
    :data:`~app.services.trends.UNLIKELY` is drawn apart, in grey: it holds only if this
    component is the worn one, which that diagnosis thought unlikely (the status text says
    so too, :func:`app.services.trends._if_blamed`).
    """
    pts = trend.points
    # a clearance in µm, as the status text and the history say it (its axis read
    # "cc [m]" with ticks 8e-05 … beside a slope in µm/day; a console pass)
    scale, unit = shown_unit(trend.unit, clearance=True)
    t0 = pts[0].measured_at.timestamp() if pts else 0.0
    days = np.array([(p.measured_at.timestamp() - t0) / 86400.0 for p in pts])
    y = np.array([p.value for p in pts]) * scale
    low = np.array([p.low if p.low is not None else p.value for p in pts]) * scale
    high = np.array([p.high if p.high is not None else p.value for p in pts]) * scale
    unlikely = np.array([p.probability is not None and p.probability < UNLIKELY for p in pts],
                        dtype=bool)
    series = []
    for part, label, color in ((~unlikely, "estimate (95 %)", PALETTE[0]),
                               (unlikely, f"if the {trend.component} is the worn one "
                                f"(p < {UNLIKELY:g})", MUTED)):
        if part.any() or (color == PALETTE[0] and not pts):  # an empty chart keeps its legend
            series.append(Series(days[part], y[part], label, kind="errorbars",
                                 low=low[part], high=high[part], color=color))
    fitted = (days > (trend.step_at.timestamp() - t0) / 86400.0 if trend.step_at is not None
              else np.ones(days.size, dtype=bool))
    if trend.slope is not None and int(fitted.sum()) >= 2:
        # Theil-Sen line: the slope with the intercept median(y - slope·t); its band pivots
        # on the middle of the data with the slope's 95 % interval; after a step in the
        # level, over the points after it (those the trend was fitted to)
        per_day = 86400.0 * scale
        slope = trend.slope * per_day
        intercept = float(np.median(y[fitted] - slope * days[fitted]))
        xm = float(np.median(days[fitted]))
        span = np.linspace(float(days[fitted].min()) if trend.step_at is not None else 0.0,
                           float(days.max()), 50)
        line = intercept + slope * span
        at_xm = intercept + slope * xm
        lo = at_xm + (trend.slope_low if trend.slope_low is not None else trend.slope) \
            * per_day * (span - xm)
        hi = at_xm + (trend.slope_high if trend.slope_high is not None else trend.slope) \
            * per_day * (span - xm)
        label = "Theil–Sen" if trend.step_at is None else \
            f"Theil–Sen since the step of {trend.step_at:%Y-%m-%d}"
        # the band within the points' and the threshold's range and half as much again
        # either side: a slope interval of −7.6e4 … 0.13 µm/day from visits seconds apart
        # drew ±1 m and flattened every point onto one line (a console pass)
        seen = np.concatenate([low, high, [trend.threshold * scale]])
        reach = float(np.ptp(seen)) or abs(float(seen.max())) or 1.0
        floor, ceiling = float(seen.min()) - 0.5 * reach, float(seen.max()) + 0.5 * reach
        band_lo = np.clip(np.minimum(lo, hi), floor, ceiling)
        band_hi = np.clip(np.maximum(lo, hi), floor, ceiling)
        series.append(Series(span, np.clip(line, floor, ceiling), label, low=band_lo,
                             high=band_hi, dashed=True, color=PALETTE[1]))
    return line_chart(f"{trend.component}: {trend.quantity} over time",
                      "days since the first diagnosis [day]",
                      f"{trend.quantity} [{unit}]", series,
                      hlines=[(trend.threshold * scale, "threshold")])


def calibration_chart(title: str, opening: Sequence[float], clearance: Sequence[float | None],
                      curve: tuple[Sequence[float], Sequence[float]] | None) -> Chart:
    """A throttle table's rows and its PCHIP curve: opening [turn] → clearance [µm]."""
    known = [(x, c) for x, c in zip(opening, clearance, strict=True) if c is not None]
    series = [Series([x for x, _ in known], [c * 1e6 for _, c in known], "table rows",
                     kind="points")]
    if curve is not None:
        series.append(Series(curve[0], [c * 1e6 for c in curve[1]], "PCHIP curve"))
    return line_chart(title, "throttle opening [turn]", "equivalent clearance [µm]", series)


def _panel(title: str, axis: str, si: str, columns: tuple[str, ...]
           ) -> tuple[str, str, tuple[str, ...], float]:
    factor, unit = shown_unit(si)
    return title, f"{axis} [{unit}]", columns, factor


#: Panels of a simulated cycle: title, y label, columns and the factor to the shown unit
#: (the plotting module's :func:`~diagnostics.plots.shown_unit`, as every chart's)
_PANELS = (
    _panel("Pressures", "pressure", "Pa", ("P_pump [Pa]", "P1 [Pa]", "P2 [Pa]")),
    _panel("Piston position", "x", "m", ("x [m]",)),
    _panel("Piston speed", "v", "m/s", ("v [m/s]",)),
    _panel("Meter flows", "flow", "m^3/s", ("Q_meter_B [m^3/s]", "Q_meter_C [m^3/s]")),
)


def simulation_charts(run: pd.DataFrame, nominal: pd.DataFrame | None,
                      label: str) -> list[Chart]:
    """A simulated cycle's pressures, position, speed and meter flows, nominal dashed."""
    charts = []
    for title, ylabel, columns, factor in _PANELS:
        series = []
        for col in columns:
            name = col.split(" ")[0]
            series.append(Series(_thin(run["t [s]"]), _thin(run[col] * factor),
                                 f"{name} ({label})"))
            if nominal is not None:
                series.append(Series(_thin(nominal["t [s]"]), _thin(nominal[col] * factor),
                                     f"{name} (nominal)", dashed=True))
        charts.append(line_chart(title, "t [s]", ylabel, series))
    return charts


def _thin(values: pd.Series, most: int = 600) -> Any:
    """At most ``most`` points of a long series (a page does not need every solver step)."""
    array = values.to_numpy(dtype=float)
    step = max(1, len(array) // most)
    return array[::step]


def surface_chart(name: str, coef: Sequence[Sequence[float]], p_ref: float, omega_ref: float,
                  dp_range: Sequence[float], omega_range: Sequence[float]) -> Chart:
    """A fitted loss-coefficient surface of paper 000 over pressure rise at three speeds.

    ``name(Δp, ω) = Σ c[i][j]·(Δp/p_ref)^i·(ω/ω_ref)^j`` drawn over the data's range.
    """
    c = np.asarray(coef, dtype=float)
    if c.ndim == 1:
        c = c[:, None]
    dp = np.linspace(float(dp_range[0]), float(dp_range[-1]), 40)
    series = []
    for omega in np.linspace(float(omega_range[0]), float(omega_range[-1]), 3):
        i = np.arange(c.shape[0])[:, None, None]
        j = np.arange(c.shape[1])[None, :, None]
        value = (c[:, :, None] * (dp / p_ref)[None, None, :] ** i
                 * (omega / omega_ref) ** j).sum(axis=(0, 1))
        series.append(Series(dp * 1e-5, value, f"n = {omega * 30.0 / math.pi:.0f} rpm"))
    return line_chart(f"{name} over pressure rise", "Δp [bar]", f"{name} [1]", series)


#: SI unit of a stored channel → (axis label, factor to the axis unit), for the series page
_AXES = {unit: (f"{quantity} [{SHOWN_UNITS[unit][0]}]", SHOWN_UNITS[unit][1])
         for unit, quantity in (("Pa", "pressure"), ("m^3/s", "flow"), ("m/s", "speed"),
                                ("m", "position"), ("degC", "temperature"), ("W", "power"),
                                ("N", "force"), ("N*m", "torque"))}


def series_charts(record: SeriesRecord, *, most: int = 600) -> list[Chart]:
    """A stored measured record's channels against time, one chart per unit (pressures in
    bar, flows in l/min, …), at most ``most`` points a line; the phases' boundaries marked
    where the record has phase labels."""
    step = max(1, len(record) // most)
    t = record.t[::step]
    marks: list[tuple[float, str]] = []
    if record.phase is not None and record.phase.size:
        change = np.flatnonzero(record.phase[1:] != record.phase[:-1]) + 1
        marks = [(float(record.t[i]), str(record.phase[i])) for i in change]
    groups: dict[str, list[str]] = {}
    for name in record.channels:
        groups.setdefault(record.units.get(name, "-"), []).append(name)
    charts = []
    for unit, names in groups.items():
        label, factor = _AXES.get(unit, (f"[{unit}]", 1.0))
        series = [Series(t, record.channels[n][::step] * factor, n) for n in names]
        title = f"{record.name}: {label.split(' [')[0]}"  # the legend names the channels
        charts.append(line_chart(title, "t [s]", label, series, vlines=marks))
    return charts


def leak_chart(answer: PumpLeakResponse) -> Chart:
    """The pump's leak at each cycle's plateau pressure [l/min] over the cycles in time
    order (``POST /rigs/{id}/pump-leak``): leaking cycles and the others apart, and the
    median of each segment between the steps as a stepped line."""
    lpm, flow = shown_unit("m^3/s")
    x = np.arange(len(answer.cycles), dtype=float)
    y = np.array([c.leak_flow * lpm if c.leak_flow is not None else math.nan
                  for c in answer.cycles])
    leaking = np.array([c.leaking for c in answer.cycles], dtype=bool)
    series = [Series(x[~leaking], y[~leaking], "not leaking", kind="points", color=PALETTE[2]),
              Series(x[leaking], y[leaking], "leaking", kind="points", color=PALETTE[1])]
    sx, sy = [], []
    for seg in segments(answer):
        level = seg.leak_flow * lpm if seg.leak_flow is not None else math.nan
        sx += [float(seg.start), float(seg.stop - 1)]
        sy += [level, level]
    series.append(Series(np.array(sx), np.array(sy), "median between steps", color=PALETTE[0]))
    return line_chart(f"rig {answer.rig_id}: the pump's leak per cycle",
                      "cycle, in time order [-]", f"leak at the plateau pressure [{flow}]",
                      series, vlines=[(float(s.index) - 0.5, "step") for s in answer.shifts])
