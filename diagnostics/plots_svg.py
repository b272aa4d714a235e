"""Charts of :mod:`diagnostics.plots` written straight to SVG, without matplotlib.

Pages need their plots fast: matplotlib takes 0.15-1.5 s per chart (1,000 error bars),
this writer a few milliseconds, so a console page with several charts renders well within
300 ms.  It draws the same :class:`~diagnostics.plots.Chart` values (lines, points,
steps, error bars, bands, bars with intervals, reference lines, category ticks, log y) in
the same palette; PNG files still come from matplotlib (:func:`diagnostics.plots.render_png`).

The output obeys the same contract as :func:`diagnostics.plots.render_svg`: no ``style``
attribute or element (presentation attributes only, safe under ``style-src 'self'``), text
escaped, and a root ``<svg class="hd-plot" role="img" aria-label=... data-points=...>`` whose
``<desc>`` says its numbers (:func:`describe`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from html import escape

import numpy as np

from diagnostics.plots import MARKERS, PALETTE, Chart, Series, line_marks, mark_indices

__all__ = ["nice_ticks", "render_svg_native"]

_FONT = 'font-family="DejaVu Sans, Arial, sans-serif"'
_GREY = "#555555"


def nice_ticks(low: float, high: float, count: int = 5) -> list[float]:
    """Round tick positions covering ``[low, high]`` (steps of 1, 2 or 5 × 10ⁿ)."""
    if not (math.isfinite(low) and math.isfinite(high)) or high <= low:
        return [low]
    raw = (high - low) / max(count, 1)
    power = 10.0 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1.0, 2.0, 5.0, 10.0) if m * power >= raw)
    first = math.ceil(low / step - 1e-9) * step
    ticks = []
    value = first
    while value <= high + 1e-9 * step:
        ticks.append(0.0 if abs(value) < 1e-12 * step else value)
        value += step
    return ticks


def _label(value: float) -> str:
    return f"{value:.3g}"


def _finite(*arrays: Iterable[float]) -> list[float]:
    out: list[float] = []
    for a in arrays:
        out += [float(v) for v in np.asarray(a, dtype=float).ravel() if math.isfinite(v)]
    return out


def _range(values: list[float], *, log: bool = False, zero: bool = False) -> tuple[float, float]:
    if zero:
        values = [*values, 0.0]
    if log:
        values = [math.log10(v) for v in values if v > 0]
    if not values:
        return (0.0, 1.0)
    lo, hi = min(values), max(values)
    if hi == lo:
        pad = abs(hi) * 0.1 or 1.0
        return lo - pad, hi + pad
    pad = 0.05 * (hi - lo)
    return (lo if zero and lo == 0.0 else lo - pad), hi + pad


class _Frame:
    """The plot area and the mapping of data to pixels."""

    def __init__(self, width: float, height: float, xr: tuple[float, float],
                 yr: tuple[float, float], *, left: float, bottom: float, logy: bool) -> None:
        self.x0, self.x1 = left, width - 16.0
        self.y0, self.y1 = height - bottom, 30.0
        self.xr, self.yr, self.logy = xr, yr, logy

    def x(self, v: float) -> float:
        return self.x0 + (v - self.xr[0]) / (self.xr[1] - self.xr[0]) * (self.x1 - self.x0)

    def y(self, v: float) -> float:
        if self.logy:
            v = math.log10(v) if v > 0 else self.yr[0]
        return self.y0 - (v - self.yr[0]) / (self.yr[1] - self.yr[0]) * (self.y0 - self.y1)


def _polyline(frame: _Frame, x: np.ndarray, y: np.ndarray, color: str, dashed: bool,
              step: bool = False) -> str:
    runs: list[list[str]] = [[]]
    last_y: float | None = None
    for xi, yi in zip(x, y, strict=True):
        if not (math.isfinite(xi) and math.isfinite(yi)) or (frame.logy and yi <= 0):
            runs.append([])
            last_y = None
            continue
        if step and last_y is not None:
            runs[-1].append(f"{frame.x(xi):.1f},{frame.y(last_y):.1f}")
        runs[-1].append(f"{frame.x(xi):.1f},{frame.y(yi):.1f}")
        last_y = yi
    dash = ' stroke-dasharray="5 3"' if dashed else ""
    return "".join(f'<polyline points="{" ".join(r)}" fill="none" stroke="{color}" '
                   f'stroke-width="1.5"{dash}/>' for r in runs if len(r) > 1)


#: half the size of a line's mark [px]
_MARK_R = 3.5


def _mark(shape: int, cx: float, cy: float) -> str:
    """Path data of mark ``shape`` (:data:`~diagnostics.plots.MARKERS`) centred on
    (``cx``, ``cy``) [px]: closed outlines, filled, except the plus and the cross, stroked."""
    r = _MARK_R
    code = MARKERS[shape][0]
    if code == "s":
        return f"M{cx - r:.1f} {cy - r:.1f}h{2 * r:.1f}v{2 * r:.1f}h{-2 * r:.1f}Z"
    if code == "^":
        return f"M{cx:.1f} {cy - r:.1f}L{cx + r:.1f} {cy + r:.1f}L{cx - r:.1f} {cy + r:.1f}Z"
    if code == "v":
        return f"M{cx:.1f} {cy + r:.1f}L{cx + r:.1f} {cy - r:.1f}L{cx - r:.1f} {cy - r:.1f}Z"
    if code == "D":
        return (f"M{cx:.1f} {cy - r:.1f}L{cx + r:.1f} {cy:.1f}L{cx:.1f} {cy + r:.1f}"
                f"L{cx - r:.1f} {cy:.1f}Z")
    if code == "P":
        return f"M{cx - r:.1f} {cy:.1f}h{2 * r:.1f}M{cx:.1f} {cy - r:.1f}v{2 * r:.1f}"
    if code == "X":
        return (f"M{cx - r:.1f} {cy - r:.1f}l{2 * r:.1f} {2 * r:.1f}"
                f"M{cx - r:.1f} {cy + r:.1f}l{2 * r:.1f} {-2 * r:.1f}")
    if code == "o":
        return (f"M{cx - r:.1f} {cy:.1f}a{r:.1f} {r:.1f} 0 1 0 {2 * r:.1f} 0"
                f"a{r:.1f} {r:.1f} 0 1 0 {-2 * r:.1f} 0Z")
    points = [(cx + (r if k % 2 == 0 else r / 2.2) * math.sin(k * math.pi / 5),
               cy - (r if k % 2 == 0 else r / 2.2) * math.cos(k * math.pi / 5)) for k in range(10)]
    return "M" + "L".join(f"{a:.1f} {b:.1f}" for a, b in points) + "Z"


def _marks(shape: int, centres: Iterable[tuple[float, float]], color: str) -> str:
    """One ``<path>`` holding mark ``shape`` at every centre [px]."""
    d = "".join(_mark(shape, cx, cy) for cx, cy in centres)
    if not d:
        return ""
    stroked = MARKERS[shape][0] in ("P", "X")
    return (f'<path d="{d}" fill="none" stroke="{color}" stroke-width="1.6"/>' if stroked
            else f'<path d="{d}" fill="{color}" stroke="none"/>')


def _series(frame: _Frame, s: Series, color: str, shape: int | None = None) -> str:
    x = np.asarray(s.x, dtype=float)
    y = np.asarray(s.y, dtype=float)
    parts = []
    if s.low is not None and s.high is not None and s.kind != "errorbars":
        lo, hi = np.asarray(s.low, dtype=float), np.asarray(s.high, dtype=float)
        ok = np.isfinite(x) & np.isfinite(lo) & np.isfinite(hi)
        if ok.sum() > 1:
            top = [f"{frame.x(a):.1f},{frame.y(b):.1f}" for a, b in zip(x[ok], hi[ok], strict=True)]
            bottom = [f"{frame.x(a):.1f},{frame.y(b):.1f}"
                      for a, b in zip(x[ok][::-1], lo[ok][::-1], strict=True)]
            parts.append(f'<polygon points="{" ".join(top + bottom)}" fill="{color}" '
                         'fill-opacity="0.18" stroke="none"/>')
    if s.kind in ("points", "errorbars"):
        if s.kind == "errorbars" and s.low is not None and s.high is not None:
            lo, hi = np.asarray(s.low, dtype=float), np.asarray(s.high, dtype=float)
            path = "".join(
                f"M{frame.x(a):.1f} {frame.y(b):.1f}V{frame.y(c):.1f}"
                f"M{frame.x(a) - 3:.1f} {frame.y(b):.1f}h6M{frame.x(a) - 3:.1f} {frame.y(c):.1f}h6"
                for a, b, c in zip(x, lo, hi, strict=True)
                if math.isfinite(a) and math.isfinite(b) and math.isfinite(c))
            parts.append(f'<path d="{path}" stroke="{color}" stroke-width="1.2" fill="none"/>')
        parts.append("".join(f'<circle cx="{frame.x(a):.1f}" cy="{frame.y(b):.1f}" r="3" '
                             f'fill="{color}"/>' for a, b in zip(x, y, strict=True)
                             if math.isfinite(a) and math.isfinite(b)))
    else:
        parts.append(_polyline(frame, x, y, color, s.dashed, step=s.kind == "step"))
        if shape is not None:
            parts.append(_marks(shape, ((frame.x(x[j]), frame.y(y[j])) for j in
                                        mark_indices(x, y, shape, logy=frame.logy)), color))
    return "".join(parts)


def _text(x: float, y: float, text: str, *, size: int = 11, anchor: str = "middle",
          extra: str = "") -> str:
    return (f'<text x="{x:.1f}" y="{y:.1f}" font-size="{size}" text-anchor="{anchor}" '
            f'{_FONT} fill="#222222"{extra}>{escape(text)}</text>')


#: height of one legend row and the gap above the legend [px]
_LEGEND_ROW, _LEGEND_GAP = 14.0, 4.0


#: a legend entry: label, colour, dashed line, drawn as a dot (a series of points), the
#: line's mark (:data:`~diagnostics.plots.MARKERS`; None for none)
_Entry = tuple[str, str, bool, bool, int | None]


def _legend_layout(entries: Sequence[_Entry], width: float) -> list[tuple[float, int]]:
    """Each legend entry's x [px] and row: left to right, wrapping within ``width``."""
    out: list[tuple[float, int]] = []
    x, row = 8.0, 0
    for text, *_ in entries:
        w = 30.0 + 6.2 * len(text) + 12.0
        if x > 8.0 and x + w > width - 8.0:
            x, row = 8.0, row + 1
        out.append((x, row))
        x += w
    return out


def _legend(entries: Sequence[_Entry], width: float, top: float) -> tuple[str, float]:
    """The legend below the plot, from ``top`` [px] down, and its height [px]: outside the
    axes, so that it never covers a point (it once hid error bars and a throttle point)."""
    if not entries:
        return "", 0.0
    layout = _legend_layout(entries, width)
    out = []
    for (text, color, dashed, dot, shape), (x, row) in zip(entries, layout, strict=True):
        yy = top + _LEGEND_GAP + 11 + _LEGEND_ROW * row
        dash = ' stroke-dasharray="5 3"' if dashed else ""
        if dot:
            out.append(f'<circle cx="{x + 12:.1f}" cy="{yy - 4:.1f}" r="3" fill="{color}"/>')
        else:
            out.append(f'<line x1="{x:.1f}" y1="{yy - 4:.1f}" x2="{x + 24:.1f}" '
                       f'y2="{yy - 4:.1f}" stroke="{color}" stroke-width="2"{dash}/>')
            if shape is not None:
                out.append(_marks(shape, [(x + 12, yy - 4)], color))
        out.append(_text(x + 30, yy, text, size=10, anchor="start"))
    rows = layout[-1][1] + 1
    return "".join(out), _LEGEND_GAP + _LEGEND_ROW * rows + 4


def _axes(frame: _Frame, chart: Chart, xticks: list[tuple[float, str]],
          yticks: list[tuple[float, str]], height: float) -> str:
    out = [f'<rect x="{frame.x0:.1f}" y="{frame.y1:.1f}" width="{frame.x1 - frame.x0:.1f}" '
           f'height="{frame.y0 - frame.y1:.1f}" fill="#ffffff" stroke="#333333"/>']
    rotate = bool(chart.xticks)
    for v, text in xticks:
        px = frame.x(v)
        out.append(f'<line x1="{px:.1f}" y1="{frame.y1:.1f}" x2="{px:.1f}" y2="{frame.y0:.1f}" '
                   'stroke="#e5e5e5"/>')
        if rotate:
            out.append(_text(px, frame.y0 + 14, text, size=9, anchor="end",
                             extra=f' transform="rotate(-20 {px:.1f} {frame.y0 + 14:.1f})"'))
        else:
            out.append(_text(px, frame.y0 + 14, text, size=10))
    for v, text in yticks:
        py = frame.y(v)
        out.append(f'<line x1="{frame.x0:.1f}" y1="{py:.1f}" x2="{frame.x1:.1f}" y2="{py:.1f}" '
                   'stroke="#e5e5e5"/>')
        out.append(_text(frame.x0 - 5, py + 3.5, text, size=10, anchor="end"))
    out.append(_text((frame.x0 + frame.x1) / 2, height - 6, chart.xlabel))
    mid = (frame.y0 + frame.y1) / 2
    out.append(_text(14, mid, chart.ylabel, extra=f' transform="rotate(-90 14 {mid:.1f})"'))
    return "".join(out)


def _bars(chart: Chart, width: float, height: float) -> tuple[str, str]:
    labels = [b.label for b in chart.bars]
    left = 20 + 6.5 * max(len(t) for t in labels) if chart.horizontal else 64.0
    values = _finite([b.value for b in chart.bars], [b.low for b in chart.bars if b.low is not None],
                     [b.high for b in chart.bars if b.high is not None],
                     [p for p, _ in chart.vlines + chart.hlines])
    vr = _range(values, zero=True)
    n = len(chart.bars)
    if chart.horizontal:
        frame = _Frame(width, height, vr, (n - 0.5, -0.5), left=left, bottom=40, logy=False)
        ticks = [(t, _label(t)) for t in nice_ticks(*vr)]
        axes = _axes(frame, chart, ticks, [], height)
        body = []
        for i, b in enumerate(chart.bars):
            color = b.color or PALETTE[0]
            y0, y1 = frame.y(i - 0.4), frame.y(i + 0.4)
            xa, xb = sorted((frame.x(0.0), frame.x(b.value)))
            body.append(f'<rect x="{xa:.1f}" y="{min(y0, y1):.1f}" width="{xb - xa:.1f}" '
                        f'height="{abs(y1 - y0):.1f}" fill="{color}"/>')
            body.append(_text(frame.x0 - 5, frame.y(i) + 4, b.label, anchor="end", size=10))
            if b.low is not None and b.high is not None:
                yc = frame.y(i)
                body.append(f'<path d="M{frame.x(b.low):.1f} {yc:.1f}H{frame.x(b.high):.1f}'
                             f'M{frame.x(b.low):.1f} {yc - 4:.1f}v8M{frame.x(b.high):.1f} '
                             f'{yc - 4:.1f}v8" stroke="#000000" stroke-width="1.4"/>')
        for p, _ in chart.vlines:
            body.append(f'<line x1="{frame.x(p):.1f}" y1="{frame.y1:.1f}" x2="{frame.x(p):.1f}" '
                        f'y2="{frame.y0:.1f}" stroke="{_GREY}" stroke-dasharray="2 2"/>')
        return axes, "".join(body)
    frame = _Frame(width, height, (-0.5, n - 0.5), vr, left=left, bottom=48, logy=False)
    axes = _axes(frame, chart, [(i, t) for i, t in enumerate(labels)],
                 [(t, _label(t)) for t in nice_ticks(*vr)], height)
    body = []
    for i, b in enumerate(chart.bars):
        ya, yb = sorted((frame.y(0.0), frame.y(b.value)))
        body.append(f'<rect x="{frame.x(i - 0.4):.1f}" y="{ya:.1f}" '
                    f'width="{frame.x(i + 0.4) - frame.x(i - 0.4):.1f}" height="{yb - ya:.1f}" '
                    f'fill="{b.color or PALETTE[0]}"/>')
        if b.low is not None and b.high is not None:
            xc = frame.x(i)
            body.append(f'<path d="M{xc:.1f} {frame.y(b.low):.1f}V{frame.y(b.high):.1f}" '
                        'stroke="#000000" stroke-width="1.4"/>')
    for p, _ in chart.hlines:
        body.append(f'<line x1="{frame.x0:.1f}" y1="{frame.y(p):.1f}" x2="{frame.x1:.1f}" '
                    f'y2="{frame.y(p):.1f}" stroke="{_GREY}" stroke-dasharray="2 2"/>')
    return axes, "".join(body)


def _lines(chart: Chart, width: float, height: float) -> tuple[str, str, list[_Entry]]:
    xs = _finite(*[s.x for s in chart.series], [p for p, _ in chart.vlines])
    ys = _finite(*[s.y for s in chart.series], *[s.low for s in chart.series if s.low is not None],
                 *[s.high for s in chart.series if s.high is not None],
                 [p for p, _ in chart.hlines])
    xr = _range(xs)
    yr = _range(ys, log=chart.logy)
    frame = _Frame(width, height, xr, yr, left=72, bottom=62 if chart.xticks else 40,
                   logy=chart.logy)
    if chart.xticks:
        xticks = [(float(i), t) for i, t in enumerate(chart.xticks)]
    else:
        xticks = [(t, _label(t)) for t in nice_ticks(*xr)]
    if chart.logy:
        yticks = [(10.0 ** e, f"1e{e}") for e in range(math.ceil(yr[0]), math.floor(yr[1]) + 1)]
    else:
        yticks = [(t, _label(t)) for t in nice_ticks(*yr)]
    axes = _axes(frame, chart, xticks, yticks, height)
    body = []
    legend: list[_Entry] = []
    marks = line_marks(chart)
    for i, s in enumerate(chart.series):
        color = s.color if s.color is not None else PALETTE[i % len(PALETTE)]
        body.append(_series(frame, s, color, marks.get(i)))
        if s.label:  # a dotted series gets a dot in the legend, a line a line (and its mark)
            legend.append((s.label, color, s.dashed, s.kind in ("points", "errorbars"),
                           marks.get(i)))
    for p, text in chart.hlines:
        if not chart.logy or p > 0:
            body.append(f'<line x1="{frame.x0:.1f}" y1="{frame.y(p):.1f}" x2="{frame.x1:.1f}" '
                        f'y2="{frame.y(p):.1f}" stroke="{_GREY}" stroke-dasharray="2 2"/>')
            if text:
                legend.append((text, _GREY, True, False, None))
    for p, text in chart.vlines:
        body.append(f'<line x1="{frame.x(p):.1f}" y1="{frame.y1:.1f}" x2="{frame.x(p):.1f}" '
                    f'y2="{frame.y0:.1f}" stroke="{_GREY}" stroke-dasharray="2 2"/>')
        if text:
            legend.append((text, _GREY, True, False, None))
    return axes, "".join(body), legend


#: series (or bars) a chart's text alternative names one by one; the rest are counted
DESCRIBED = 8


def _span(values: np.ndarray) -> str:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "no values"
    lo, hi = float(v.min()), float(v.max())
    return f"{lo:.4g}" if f"{lo:.4g}" == f"{hi:.4g}" else f"{lo:.4g} to {hi:.4g}"


def describe(chart: Chart) -> str:
    """The chart in words with its numbers, its ``<desc>`` (the accessible description of
    an SVG of role img; the title is its name): each bar's value (and
    interval), or the x range and each series' points and y range, in the axes' units.  The
    alternative was the title alone: a screen reader heard "Pump flow" and nothing of the
    curves whose numbers the page shows nowhere else (an accessibility pass)."""
    parts = [chart.title]
    if chart.bars:
        bars = [f"{b.label} {b.value:.4g}" + (f" ({b.low:.4g} to {b.high:.4g})"
                                               if b.low is not None and b.high is not None
                                               else "") for b in chart.bars[:DESCRIBED]]
        parts.append((f"{chart.ylabel or chart.xlabel}: " if (chart.ylabel or chart.xlabel)
                      else "") + "; ".join(bars))
    else:
        xs = [np.asarray(s.x, dtype=float) for s in chart.series]
        if xs:
            parts.append(f"{chart.xlabel or 'x'} {_span(np.concatenate(xs))}")
        named = ""
        marks = line_marks(chart)
        for i, s in enumerate(chart.series[:DESCRIBED]):
            y = np.asarray(s.y, dtype=float)
            # a line drawn without a legend entry goes with the series before it (a pump
            # chart's model beside its points read "series 2": a verification pass)
            name = s.label or (f"{named}, {'dashed ' if s.dashed else ''}line" if named
                               else f"series {i + 1}")
            named = s.label or named
            if i in marks:  # the shape that tells it apart on the chart
                name += f" ({MARKERS[marks[i]][1]} marks)"
            parts.append(f"{name}: {y.size} points, {chart.ylabel or 'y'} {_span(y)}")
    left = len(chart.bars or chart.series) - DESCRIBED
    if left > 0:
        parts.append(f"and {left} more")
    return ". ".join(parts)


def render_svg_native(chart: Chart) -> str:
    """The chart as an SVG element, written directly (module docstring)."""
    width, height = chart.size[0] * 100.0, chart.size[1] * 100.0
    legend, extra = "", 0.0
    if chart.bars:
        axes, body = _bars(chart, width, height)
    else:
        axes, body, entries = _lines(chart, width, height)
        legend, extra = _legend(entries, width, height)
    title = escape(chart.title, quote=True)
    total = height + extra
    return (f'<svg class="hd-plot" role="img" aria-label="{title}" '
            f'data-points="{chart.points}" xmlns="http://www.w3.org/2000/svg" '
            f'width="{width:.0f}" height="{total:.0f}" viewBox="0 0 {width:.0f} {total:.0f}">'
            f'<desc>{escape(describe(chart))}</desc>'
            f'<rect width="100%" height="100%" fill="#ffffff"/>'
            f'{_text(width / 2, 18, chart.title, size=12)}{axes}{body}{legend}</svg>')
