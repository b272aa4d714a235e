"""The plotting module: charts render to CSP-safe SVG that carries its data, and to PNG."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np

from diagnostics.plots import Bar, Series, bar_chart, line_chart, render_png, render_svg


def _chart():
    t = np.linspace(0.0, 2.0, 200)
    v = 0.18 * (1 - np.exp(-t / 0.05))
    return line_chart("Piston speed", "t [s]", "v [m/s]", [
        Series(t, v, "measured", kind="points"),
        Series(t, v * 1.01, "model", dashed=True, low=v * 0.99, high=v * 1.03),
    ], hlines=[(0.18, "nominal")])


def test_svg_is_csp_safe_and_carries_the_data():
    svg = render_svg(_chart())
    root = ET.fromstring(svg)  # well-formed XML
    assert root.attrib["class"] == "hd-plot"
    assert root.attrib["data-points"] == "400"
    assert root.attrib["aria-label"] == "Piston speed"
    assert " style=" not in svg and "<style" not in svg  # nothing a strict CSP would block
    assert "<script" not in svg
    # the model line is a polyline through all 200 points, the measurements 200 markers
    lines = [e for e in root.iter() if e.tag.endswith("polyline")
             and len(e.attrib.get("points", "").split()) == 200]
    assert lines, "the data series is drawn"
    assert sum(1 for e in root.iter() if e.tag.endswith("circle")) >= 200
    assert re.search(r'stroke="#d55e00"', svg, re.I)
    assert "t [s]" in svg and "v [m/s]" in svg  # axis labels stay text
    # its numbers for a screen reader (the title alone was its text alternative: an
    # accessibility pass), the description of the img
    (desc,) = [e.text for e in root if e.tag.endswith("desc")]
    assert desc == ("Piston speed. t [s] 0 to 2. measured: 200 points, v [m/s] 0 to 0.18. "
                    "model: 200 points, v [m/s] 0 to 0.1818")


def test_bars_and_png():
    chart = bar_chart("Hypotheses", "probability [-]", [
        Bar("valve", 0.81, 0.7, 0.9), Bar("pump", 0.12), Bar("healthy", 0.07)])
    svg = render_svg(chart)
    assert 'data-points="3"' in svg and "valve" in svg
    png = render_png(chart)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 2000


def test_the_legend_is_below_the_plot_and_covers_no_point():
    """Legend entries sit under the axes (the svg grows to hold them, wrapping into rows),
    never over a point: the legend box once hid error bars and a throttle point."""
    names = [f"hypothesis number {k}" for k in range(7)]
    x = np.arange(5.0)
    chart = line_chart("Measured vs predicted", "", "reading [σ]",
                       [Series(x, x * 0.1 * k, name, kind="points") for k, name in
                        enumerate(names)], hlines=[(0.0, "nominal")])
    root = ET.fromstring(render_svg(chart))
    frame = next(e for e in root.iter() if e.tag.endswith("rect")
                 and e.attrib.get("stroke") == "#333333")
    bottom = float(frame.attrib["y"]) + float(frame.attrib["height"])
    circles = [float(e.attrib["cy"]) for e in root.iter() if e.tag.endswith("circle")]
    # every point inside the axes; below them only the legend's dots, one per series
    assert sum(c <= bottom for c in circles) == 5 * len(names)
    assert sum(c > bottom for c in circles) == len(names)
    texts = {e.text: e for e in root.iter() if e.tag.endswith("text")}
    rows = set()
    for name in [*names, "nominal"]:
        y = float(texts[name].attrib["y"])
        assert bottom < y <= float(root.attrib["height"]), name
        assert float(texts[name].attrib["x"]) < float(root.attrib["width"])
        rows.add(y)
    assert len(rows) >= 2  # eight entries do not fit in one row of 700 px
    assert float(root.attrib["height"]) > 320.0
    # no legend, no extra height
    bare = line_chart("Speed", "t [s]", "v [m/s]", [Series(x, x)])
    assert ET.fromstring(render_svg(bare)).attrib["height"] == "320"


def test_a_line_without_a_legend_entry_is_described_with_the_series_before_it():
    # a pump chart's model line beside its points read "series 2" (a verification pass)
    from diagnostics.plots_svg import describe

    x = np.arange(3.0)
    chart = line_chart("Flow: measured and model", "Δp [bar]", "q [l/min]", [
        Series(x, x, "1450 rpm", kind="points"), Series(x, 1.1 * x, "", dashed=True)])
    assert describe(chart) == ("Flow: measured and model. Δp [bar] 0 to 2. 1450 rpm: 3 points, "
                               "q [l/min] 0 to 2. 1450 rpm, dashed line: 3 points, q [l/min] "
                               "0 to 2.2")
    bars = bar_chart("Hypotheses", "probability [-]", [Bar("valve", 0.7, 0.6, 0.8)])
    assert describe(bars) == "Hypotheses. probability [-]: valve 0.7 (0.6 to 0.8)"


def test_lines_are_told_apart_by_shape_as_well_as_colour():
    """Two or more labelled lines each carry their own mark along the line and in the
    legend, in the SVG and in the PNG's figure, and the description names it (P_pump, P1
    and P2 were told apart by colour alone: an accessibility pass, WCAG 1.4.1)."""
    from diagnostics.plots import MARKERS, MARKS_PER_LINE, PALETTE, _figure, line_marks
    from diagnostics.plots_svg import describe

    t = np.linspace(0.0, 2.0, 300)
    lines = [Series(t, 100.0 + k * 10.0 + np.sin(t), name) for k, name in
             enumerate(("P_pump", "P1", "P2"))]
    chart = line_chart("Pressures", "t [s]", "p [bar]",
                       [*lines, Series(t[::30], 90.0 + t[::30], "measured", kind="points")])
    assert line_marks(chart) == {0: 0, 1: 1, 2: 2}
    root = ET.fromstring(render_svg(chart))
    frame = next(e for e in root.iter() if e.tag.endswith("rect")
                 and e.attrib.get("stroke") == "#333333")
    bottom = float(frame.attrib["y"]) + float(frame.attrib["height"])
    marks = [e for e in root.iter() if e.tag.endswith("path") and e.attrib.get("fill") != "none"]
    # per line one path of marks on the plot and one in the legend, in the line's colour
    colours = [m.attrib["fill"] for m in marks]
    assert colours == [PALETTE[0], PALETTE[1], PALETTE[2]] * 2
    for m in marks[:3]:  # six closed outlines each, every vertex inside the axes
        assert m.attrib["d"].count("Z") == MARKS_PER_LINE
        ys = [float(v) for v in re.findall(r"[ML][\d.]+ ([\d.]+)", m.attrib["d"])]
        assert ys and max(ys) < bottom
    assert len({m.attrib["d"][:1] + str(m.attrib["d"].count("L")) for m in marks[:3]}) == 3
    assert describe(chart).startswith(
        f"Pressures. t [s] 0 to 2. P_pump ({MARKERS[0][1]} marks): 300 points")
    axes = _figure(chart).axes[0]
    assert [ln.get_marker() for ln in axes.get_lines()[:4]] == ["s", "^", "D", "o"]
    assert len(axes.get_lines()[0].get_markevery()) == MARKS_PER_LINE
    # one labelled line, or unlabelled lines beside points: nothing to tell apart by shape
    single = line_chart("Speed", "t [s]", "v [m/s]", [lines[0], Series(t, t, "", dashed=True)])
    assert line_marks(single) == {}
    assert "<path" not in render_svg(single) and "marks" not in describe(single)
