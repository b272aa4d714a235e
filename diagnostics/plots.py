"""hydrodiag's one plotting module: charts as data, rendered to SVG (pages) or PNG (files).

The console's pages, the CLI's reports and the discrepancy workflow's report all draw
through this module, so a trend looks the same everywhere.  A chart is a plain value —
:class:`Chart` holding :class:`Series` (lines, points, steps, each optionally with a band),
reference lines and labelled bars — built by :func:`line_chart` or :func:`bar_chart` and
rendered by :func:`render_svg` (written directly as SVG by :mod:`diagnostics.plots_svg`,
fast enough for pages) or :func:`render_png` (matplotlib, Agg backend, imported only when a
PNG is rendered).

SVG output is safe under a strict Content-Security-Policy (``style-src 'self'``): text is
kept as text and every style is an SVG presentation attribute (``fill="..."``,
``stroke-width="..."``), which a policy does not block; there is no ``<style>`` element.
The root ``<svg>`` carries ``class="hd-plot"``, ``role="img"``, an ``aria-label`` (the
title) and ``data-points`` (the number of data points drawn), so a browser test can check
that a plot holds data.
"""

from __future__ import annotations

import io
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

__all__ = ["MARKERS", "MUTED", "SHOWN_UNITS", "Bar", "Chart", "Series", "bar_chart", "line_chart",
           "line_marks", "mark_indices", "render_png", "render_png_stack", "render_svg",
           "shown_unit"]

Arr = npt.NDArray[np.float64]

#: colours of successive series: Okabe-Ito's colour-blind-safe hues, the orange, sky blue
#: and yellow darkened to 3:1 or more against the white chart (#E69F00 2.25, #56B4E9 2.31,
#: #F0E442 1.32 were below the 3:1 WCAG asks of a graphic: an accessibility pass)
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#B26B00", "#2C88C4", "#000000",
           "#8C7B00")
#: a muted series (a hypothesis that cannot be told, an unlikely point): 4.5:1 on white
MUTED = "#767676"
#: shapes that tell a chart's lines apart beside their colour, as matplotlib's marker codes
#: and the names a chart's description says: P_pump, P1 and P2 were told apart by colour
#: alone (WCAG 1.4.1, use of colour: an accessibility pass)
MARKERS = (("s", "square"), ("^", "triangle"), ("D", "diamond"), ("v", "inverted triangle"),
           ("P", "plus"), ("X", "cross"), ("o", "circle"), ("*", "star"))
#: marks along each line of a chart with several lines [-]
MARKS_PER_LINE = 6

#: SI unit → (the unit charts and pages show it in, the factor to it): pressures in bar,
#: flows in l/min, positions in mm, …; SI stays inside, in the API and in its files
SHOWN_UNITS: dict[str, tuple[str, float]] = {
    "Pa": ("bar", 1e-5), "m^3/s": ("l/min", 6e4), "m/s": ("m/s", 1.0), "m": ("mm", 1e3),
    "degC": ("°C", 1.0), "W": ("kW", 1e-3), "N": ("kN", 1e-3), "N*m": ("N·m", 1.0),
    "m^3/rev": ("cm³/rev", 1e6), "rad/s": ("rpm", 30.0 / math.pi),
    "m^2/s": ("cSt", 1e6), "m^3": ("L", 1e3),
}


def shown_unit(unit: str, *, clearance: bool = False) -> tuple[float, str]:
    """(factor, unit) in which a quantity of SI ``unit`` is shown (:data:`SHOWN_UNITS`;
    value × factor is in the returned unit); ``clearance``: a length in µm, as the
    history and the status texts say a clearance (:func:`sim.units.quantity_text`)."""
    if clearance and unit == "m":
        return 1e6, "µm"
    # a unit written with superscripts (the schema's "m³/s") is the same unit
    shown, factor = SHOWN_UNITS.get(unit.replace("³", "^3").replace("²", "^2"), (unit, 1.0))
    return factor, shown


#: matplotlib's global state is not thread-safe: one render at a time per process
_RENDER_LOCK = threading.Lock()


@dataclass(frozen=True)
class Series:
    """One data series.

    Attributes
    ----------
    x, y
        Coordinates [units of the axes].
    label
        Legend entry ("" for none).
    kind
        ``"line"``, ``"points"`` (markers), ``"step"`` (held until the next x) or
        ``"errorbars"`` (points with ``low``/``high`` as vertical bars).
    low, high
        Optional band (a shaded interval around a line) or error bars [y units].
    dashed
        Draw the line dashed (a model or a reference next to measurements).
    color
        A colour; by default the next of :data:`PALETTE`.
    """

    x: Sequence[float] | Arr
    y: Sequence[float] | Arr
    label: str = ""
    kind: Literal["line", "points", "step", "errorbars"] = "line"
    low: Sequence[float] | Arr | None = None
    high: Sequence[float] | Arr | None = None
    dashed: bool = False
    color: str | None = None


@dataclass(frozen=True)
class Bar:
    """One labelled bar, optionally with an interval [value units]."""

    label: str
    value: float
    low: float | None = None
    high: float | None = None
    color: str | None = None


@dataclass(frozen=True)
class Chart:
    """What to draw: series or bars, axes labels with units, reference lines.

    Attributes
    ----------
    title
        Title (also the SVG's accessible name).
    xlabel, ylabel
        Axis labels, units in brackets (``"t [s]"``).
    series
        Series of an x-y chart.
    bars
        Bars of a bar chart (horizontal when ``horizontal``).
    hlines, vlines
        Reference lines ``(position, label)`` (a threshold, a nominal value, a phase switch).
    logy
        Logarithmic y axis.
    size
        Figure size [inch] (at 100 dpi in SVG px).
    """

    title: str
    xlabel: str = ""
    ylabel: str = ""
    series: tuple[Series, ...] = ()
    bars: tuple[Bar, ...] = ()
    horizontal: bool = False
    hlines: tuple[tuple[float, str], ...] = ()
    vlines: tuple[tuple[float, str], ...] = ()
    logy: bool = False
    size: tuple[float, float] = (7.0, 3.2)
    notes: tuple[str, ...] = field(default=())
    #: labels of the x positions 0, 1, 2, ... (categories on an x-y chart)
    xticks: tuple[str, ...] = ()

    @property
    def points(self) -> int:
        """Number of data points the chart draws."""
        return sum(len(np.asarray(s.x)) for s in self.series) + len(self.bars)


def line_chart(title: str, xlabel: str, ylabel: str, series: Sequence[Series], *,
               hlines: Sequence[tuple[float, str]] = (), vlines: Sequence[tuple[float, str]] = (),
               logy: bool = False, size: tuple[float, float] = (7.0, 3.2),
               xticks: Sequence[str] = ()) -> Chart:
    """An x-y chart of ``series`` (see :class:`Chart`); ``xticks`` name x = 0, 1, 2, ..."""
    return Chart(title, xlabel, ylabel, tuple(series), (), False, tuple(hlines), tuple(vlines),
                 logy, size, xticks=tuple(xticks))


def bar_chart(title: str, label: str, bars: Sequence[Bar], *, horizontal: bool = True,
              reference: Sequence[tuple[float, str]] = (),
              size: tuple[float, float] | None = None) -> Chart:
    """A bar chart; ``label`` names the value axis with its unit; ``reference`` lines on it."""
    height = max(1.6, 0.35 * len(bars) + 0.9) if horizontal else 3.2
    dims = size if size is not None else (7.0, height)
    if horizontal:
        return Chart(title, label, "", (), tuple(bars), True, (), tuple(reference), False, dims)
    return Chart(title, "", label, (), tuple(bars), False, tuple(reference), (), False, dims)


def line_marks(chart: Chart) -> dict[int, int]:
    """Index of each labelled line (and step) series of ``chart`` → index of its shape in
    :data:`MARKERS`, where the chart has two such lines or more (one line needs no mark:
    points and bars differ from it by form already; an unlabelled line goes with the series
    before it in its colour, a pump map's model beside its points, and has no legend entry
    to show a mark in)."""
    lines = [i for i, s in enumerate(chart.series) if s.kind in ("line", "step") and s.label]
    return {i: k % len(MARKERS) for k, i in enumerate(lines)} if len(lines) >= 2 else {}


def mark_indices(x: Sequence[float] | Arr, y: Sequence[float] | Arr, shape: int, *,
                 logy: bool = False) -> list[int]:
    """Indices of the :data:`MARKS_PER_LINE` points of a line that carry its mark: spread
    evenly over its drawable points, each shape ``shape`` shifted along the line so that two
    lines on top of each other still show both marks."""
    xa, ya = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(xa) & np.isfinite(ya) & ((ya > 0) if logy else True)
    drawable = np.flatnonzero(ok)
    if drawable.size == 0:
        return []
    m = min(MARKS_PER_LINE, drawable.size)
    offset = (0.5 + 0.37 * shape) % 1.0
    at = np.floor((np.arange(m) + offset) / m * drawable.size).astype(int)
    return sorted({int(drawable[min(j, drawable.size - 1)]) for j in at})


def _color(i: int, given: str | None) -> str:
    return given if given is not None else PALETTE[i % len(PALETTE)]


def _figure(chart: Chart) -> Any:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    plt.rcParams["svg.fonttype"] = "none"
    fig, ax = plt.subplots(figsize=chart.size, dpi=100)
    if chart.bars:
        labels = [b.label for b in chart.bars]
        values = np.array([b.value for b in chart.bars], dtype=float)
        pos = np.arange(len(labels))
        colors = [_color(0, b.color) for b in chart.bars]
        lows = np.array([b.value - b.low if b.low is not None else 0.0 for b in chart.bars])
        highs = np.array([b.high - b.value if b.high is not None else 0.0 for b in chart.bars])
        err = np.vstack([lows, highs]) if (lows.any() or highs.any()) else None
        if chart.horizontal:
            ax.barh(pos, values, color=colors, xerr=err, capsize=3)
            ax.set_yticks(pos, labels)
            ax.invert_yaxis()
        else:
            ax.bar(pos, values, color=colors, yerr=err, capsize=3)
            ax.set_xticks(pos, labels)
    marks = line_marks(chart)
    for i, s in enumerate(chart.series):
        x = np.asarray(s.x, dtype=float)
        y = np.asarray(s.y, dtype=float)
        c = _color(i, s.color)
        ls = "--" if s.dashed else "-"
        shape: dict[str, Any] = {}
        if i in marks:
            shape = {"marker": MARKERS[marks[i]][0], "ms": 5,
                     "markevery": mark_indices(x, y, marks[i], logy=chart.logy)}
        if s.kind == "points":
            ax.plot(x, y, "o", ms=3.5, color=c, label=s.label or None)
        elif s.kind == "step":
            ax.step(x, y, where="post", color=c, ls=ls, lw=1.4, label=s.label or None, **shape)
        elif s.kind == "errorbars":
            lo = y - np.asarray(s.low, dtype=float) if s.low is not None else None
            hi = np.asarray(s.high, dtype=float) - y if s.high is not None else None
            yerr = np.vstack([lo, hi]) if lo is not None and hi is not None else None
            ax.errorbar(x, y, yerr=yerr, fmt="o", ms=3.5, color=c, capsize=2,
                        label=s.label or None)
        else:
            ax.plot(x, y, color=c, ls=ls, lw=1.4, label=s.label or None, **shape)
        if s.low is not None and s.high is not None and s.kind != "errorbars":
            ax.fill_between(x, np.asarray(s.low, dtype=float), np.asarray(s.high, dtype=float),
                            color=c, alpha=0.18, lw=0)
    for pos_y, text in chart.hlines:
        ax.axhline(pos_y, color="#555555", ls=":", lw=1.1, label=text or None)
    for pos_x, text in chart.vlines:
        ax.axvline(pos_x, color="#555555", ls=":", lw=1.1, label=text or None)
    if chart.xticks:
        ax.set_xticks(np.arange(len(chart.xticks)), chart.xticks, rotation=20, fontsize=8)
    if chart.logy:
        ax.set_yscale("log")
    ax.set_title(chart.title, fontsize=11)
    ax.set_xlabel(chart.xlabel)
    ax.set_ylabel(chart.ylabel)
    ax.grid(True, color="#e5e5e5", lw=0.6)
    ax.set_axisbelow(True)
    handles, _ = ax.get_legend_handles_labels()
    fig.tight_layout()
    if handles:
        # below the axes, never over a point (``loc="best"`` once hid error bars): the
        # figure grows to hold it when saved (``bbox_inches="tight"``)
        below = -0.32 if chart.xticks else (-0.2 if chart.xlabel else -0.1)  # under the labels
        ax.legend(fontsize=8, frameon=False, loc="upper center", ncol=min(len(handles), 3),
                  bbox_to_anchor=(0.5, below))
    return fig


def render_svg(chart: Chart) -> str:
    """The chart as an inline SVG document: CSP-safe, marked for tests (module docstring).

    Written directly by :mod:`diagnostics.plots_svg` (milliseconds per chart, where
    matplotlib's SVG backend took 0.15-1.5 s), from the same :class:`Chart` as the PNG.
    """
    from diagnostics.plots_svg import render_svg_native

    return render_svg_native(chart)


def render_png(chart: Chart, *, dpi: int = 110) -> bytes:
    """The chart as a PNG image (for files: CLI reports, work orders)."""
    import matplotlib.pyplot as plt

    with _RENDER_LOCK:
        fig = _figure(chart)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight", pad_inches=0.08)
        plt.close(fig)
    return buf.getvalue()


def render_png_stack(charts: Sequence[Chart], *, dpi: int = 110) -> bytes:
    """Several charts as one PNG image, one below the other (a report as a single file)."""
    if not charts:
        raise ValueError("no chart to render")
    import matplotlib.image as mpimg

    images = [mpimg.imread(io.BytesIO(render_png(c, dpi=dpi)), format="png") for c in charts]
    width = max(im.shape[1] for im in images)
    padded = [np.pad(im, ((0, 0), (0, width - im.shape[1]), (0, 0)), constant_values=1.0)
              for im in images]
    buf = io.BytesIO()
    mpimg.imsave(buf, np.vstack(padded), format="png")
    return buf.getvalue()
