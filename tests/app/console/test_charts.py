"""The console's charts and the direct SVG writer: geometry, contract, hand-checked values."""

from __future__ import annotations

import io
import re
from dataclasses import replace
from datetime import UTC, datetime, timedelta

import matplotlib.image as mpimg
import numpy as np
import pytest

from app.console.charts import SEVERITY_BANDS, estimate_charts, reading_chart, trend_chart
from app.services.trends import ComponentTrendOut, TrendPointOut
from diagnostics.plots import (
    MUTED,
    PALETTE,
    Bar,
    Series,
    bar_chart,
    line_chart,
    render_png,
    render_png_stack,
)
from diagnostics.plots_svg import nice_ticks, render_svg_native


def test_nice_ticks_are_round_and_cover_the_range() -> None:
    assert nice_ticks(0.0, 1.0) == pytest.approx([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
    assert nice_ticks(3.4e-5, 5.6e-5) == pytest.approx([3.5e-5, 4.0e-5, 4.5e-5, 5.0e-5,
                                                        5.5e-5])
    assert nice_ticks(-3.0, 7.0) == pytest.approx([-2.0, 0.0, 2.0, 4.0, 6.0])


def test_svg_obeys_the_plot_contract_and_places_points_linearly() -> None:
    chart = line_chart("A <b> & c", "x [s]", "y [m]", [
        Series([0.0, 1.0, 2.0], [0.0, 10.0, 20.0], "line"),
        Series([0.0, 2.0], [5.0, 15.0], "pts", kind="errorbars", low=[4.0, 14.0],
               high=[6.0, 16.0]),
    ], hlines=[(12.0, "limit")])
    svg = render_svg_native(chart)
    assert svg.startswith('<svg class="hd-plot" role="img" aria-label="A &lt;b&gt; &amp; c" '
                          'data-points="5"')
    assert "style" not in svg and "<script" not in svg
    # the line's three vertices are equally spaced in x and in y (a straight line)
    points = re.search(r'<polyline points="([^"]+)"', svg)
    assert points is not None
    xy = np.array([[float(v) for v in p.split(",")] for p in points.group(1).split()])
    assert np.diff(xy[:, 0]) == pytest.approx([np.diff(xy[:, 0])[0]] * 2, abs=0.11)
    assert np.diff(xy[:, 1]) == pytest.approx([np.diff(xy[:, 1])[0]] * 2, abs=0.11)
    assert np.diff(xy[:, 1])[0] < 0  # larger y is higher on the page
    # the two points, and the legend's dot for their series (below the axes)
    assert svg.count("<circle") == 3 and "limit" in svg


def test_bars_are_as_long_as_their_values() -> None:
    svg = render_svg_native(bar_chart("p", "probability [1]",
                                      [Bar("a", 0.75), Bar("b", 0.25)]))
    widths = [float(w) for w in re.findall(r'<rect x="[^"]+" y="[^"]+" width="([^"]+)" '
                                           r'height="[^"]+" fill="#0072B2"', svg)]
    assert len(widths) == 2 and widths[0] / widths[1] == pytest.approx(3.0, rel=0.01)


def test_png_stack_is_the_charts_one_below_the_other() -> None:
    charts = [line_chart("a", "x", "y", [Series([0, 1], [0, 1])]),
              bar_chart("b", "v", [Bar("x", 1.0)])]
    heights = [mpimg.imread(io.BytesIO(render_png(c)), format="png").shape[0] for c in charts]
    stacked = mpimg.imread(io.BytesIO(render_png_stack(charts)), format="png")
    assert stacked.shape[0] == sum(heights)


def _trend(values: list[float]) -> ComponentTrendOut:
    start = datetime(2026, 1, 1, tzinfo=UTC)
    points = [TrendPointOut(i + 1, start + timedelta(days=i), 1, v, v - 1e-6, v + 1e-6, 0.9)
              for i, v in enumerate(values)]
    slope = 2e-6 / 86400.0  # [m/s]
    return ComponentTrendOut("valve", "cv", "m", points, slope, slope * 0.5, slope * 1.5,
                             54e-6, "given", "worsening", None, None, None, None, "")


def test_the_theil_sen_line_passes_through_exact_linear_data() -> None:
    values = [34e-6 + 2e-6 * day for day in range(5)]
    chart = trend_chart(_trend(values))
    line = chart.series[1]
    # the line at day 0 and at the last day is the data there: intercept median(y − s·t);
    # a clearance drawn in µm, as the status text and the history say it
    assert line.y[0] == pytest.approx(values[0] * 1e6, rel=1e-9)
    assert line.y[-1] == pytest.approx(values[-1] * 1e6, rel=1e-9)
    assert chart.hlines == ((pytest.approx(54.0), "threshold"),)
    assert chart.ylabel == "cv [µm]"
    assert chart.points == 5 + 50


def test_a_slope_interval_wider_than_the_data_is_drawn_within_it() -> None:
    """Visits seconds apart gave a slope interval of −7.6e4 … 0.13 µm/day, whose band
    drew ±1 m and flattened the points onto one line (a console pass): the band stays
    within the points' and the threshold's range and half as much again either side."""
    values = [34e-6 + 2e-6 * day for day in range(5)]
    trend = replace(_trend(values), slope_low=-1.0, slope_high=1.0)   # ±86 km/day
    line = trend_chart(trend).series[1]
    span = 54.0 - (34.0 - 1.0)                 # threshold to the lowest interval [µm]
    assert float(np.min(line.low)) == pytest.approx(33.0 - 0.5 * span)
    assert float(np.max(line.high)) == pytest.approx(54.0 + 0.5 * span)
    assert line.y[0] == pytest.approx(34.0, rel=1e-9)      # the line itself is inside


def test_after_a_step_the_line_is_drawn_over_the_points_after_it() -> None:
    """The trend of a stepped spool is fitted to the visits after the step; a line over
    every point read the step as wear on the page."""
    values = [34e-6] * 5 + [46e-6 + 1e-6 * day for day in range(5)]
    trend = replace(_trend(values), slope=1e-6 / 86400.0,
                    step_at=datetime(2026, 1, 5, 12, tzinfo=UTC), step_size=12e-6)
    chart = trend_chart(trend)
    line = chart.series[1]
    assert line.x[0] == pytest.approx(5.0) and line.x[-1] == pytest.approx(9.0)
    assert line.y[0] == pytest.approx(46.0, rel=1e-9)
    assert line.label == "Theil–Sen since the step of 2026-01-05"


def test_estimates_of_a_component_its_diagnosis_thought_unlikely_are_drawn_apart() -> None:
    values = [34e-6 + 2e-6 * day for day in range(5)]
    trend = _trend(values)
    trend.points[3] = replace(trend.points[3], probability=0.2)  # another component named
    chart = trend_chart(trend)
    likely, unlikely, line = chart.series
    assert list(likely.y) == pytest.approx([v * 1e6 for v in values[:3] + values[4:]])
    assert list(unlikely.y) == pytest.approx([values[3] * 1e6])
    assert unlikely.label == "if the valve is the worn one (p < 0.5)" and unlikely.color == MUTED
    # the Theil–Sen line still fits every point
    assert line.y[0] == pytest.approx(values[0] * 1e6, rel=1e-9)


def test_estimates_are_drawn_as_multiples_of_nominal_with_the_severity_bands() -> None:
    result = {
        "hypotheses": [{"name": "valve", "probability": 0.7, "parameters": [
            {"name": "cv", "nominal": 34e-6}]}],
        "estimates": {"valve": {"quantity": "cv", "unit": "m", "value": 51e-6, "low": 49e-6,
                                "high": 53e-6}},
    }
    (chart,) = estimate_charts(result)
    (bar,) = chart.bars
    assert (bar.value, bar.low, bar.high) == pytest.approx((1.5, 49 / 34, 53 / 34))
    # 1.5 × nominal: leakage × 3.4, "moderate" (2.2 ≤ (c/c0)³ < 4.1)
    assert SEVERITY_BANDS[1][1] ** 3 == pytest.approx(2.2)
    assert bar.color == PALETTE[4]        # moderate


def test_readings_are_drawn_relative_to_the_measurement() -> None:
    result = {"hypotheses": [{"name": "valve", "probability": 0.9,
                              "predicted": [{"p1": 1.01e6, "flow_B": 4.9e-4}]}]}
    chart = reading_chart(result, {"p1": (1.0e6, 5e3), "flow_B": (5.0e-4, 2.5e-6)})
    assert chart is not None and chart.xticks == ("p1", "flow_B")
    measured, valve = chart.series
    assert measured.high == pytest.approx([1.96 * 5e3 / 1e6, 1.96 * 2.5e-6 / 5e-4], rel=1e-3)
    assert valve.y == pytest.approx([0.01, -0.02])


def test_pump_check_charts_draw_measured_model_and_residuals_by_speed() -> None:
    from app.console.pump_charts import pump_check_charts

    # two speeds × three pressures at one temperature; model = measured − 0.1 l/min, − 2 N·m
    dp = np.array([1e7, 2e7, 3e7] * 2)
    w = np.array([100.0] * 3 + [300.0] * 3)
    q = 1e-5 * w / 100.0 - 1e-13 * dp
    torque = 2e-6 * dp + 5.0
    quantities = {
        "points_dp": {"value": dp.tolist()}, "points_omega": {"value": w.tolist()},
        "points_theta": {"value": [50.0] * 6}, "points_q": {"value": q.tolist()},
        "points_T": {"value": torque.tolist()},
        "points_q_held_out": {"value": (q - 0.1 / 60e3).tolist()},
        "points_T_held_out": {"value": (torque - 2.0).tolist()},
    }
    flow, torque_chart, flow_res, torque_res, eff = pump_check_charts(quantities)
    assert flow.points == 12 and flow.ylabel == "q [l/min]" and flow.xlabel == "Δp [bar]"
    # per speed: measured points, then the model's dashed line in the same colour
    first, line = flow.series[0], flow.series[1]
    assert first.label == "955 rpm" and first.kind == "points" and line.dashed
    assert first.color == line.color
    assert np.allclose(first.x, [100.0, 200.0, 300.0])
    assert np.allclose(flow_res.series[0].y, 0.1) and np.allclose(torque_res.series[1].y, 2.0)
    # efficiency Δp·q/(T·ω) [%], by hand at the first point
    assert eff.series[0].y[0] == pytest.approx(100 * 1e7 * q[0] / (torque[0] * 100.0))
    assert torque_chart.points == 12
    # a set without checked points (hand-made, or not checkable) draws none of them
    assert pump_check_charts({"D": {"value": 1e-6}}) == []
    assert pump_check_charts(quantities | {"points_T": {"value": [1.0]}}) == []


def test_a_joint_diagnosis_draws_its_stored_record_with_the_weighed_sigma() -> None:
    """Record 1 of a joint diagnosis is the stored one (``record_index``): its predictions
    are drawn, and beside the instrument's bar the σ the diagnosis weighed it by."""
    result = {"record_index": 1,
              "reading_sigma": [{"p1": 9e3}, {"p1": 2e4}],
              "hypotheses": [{"name": "valve", "probability": 0.9,
                              "predicted": [{"p1": 5.0e5}, {"p1": 1.01e6}]}]}
    chart = reading_chart(result, {"p1": (1.0e6, 5e3)})
    assert chart is not None
    measured, weighed, valve = chart.series
    assert measured.high == pytest.approx([1.96 * 5e3 / 1e6], rel=1e-3)
    assert weighed.high == pytest.approx([1.96 * 2e4 / 1e6], rel=1e-3)
    assert valve.y == pytest.approx([0.01])


def test_an_unexplained_diagnosis_charts_relative_fit_not_probability() -> None:
    """Under "unexplained (p = 0)" a full blue bar at 1.0 read as the answer (a plant
    operator's pass): the chart says what its bars are."""
    from app.console.charts import probability_chart

    result = {"explained": False, "hypotheses": [
        {"name": "cylinder+pump", "probability": 1.0}, {"name": "valve", "probability": 0.0}]}
    chart = probability_chart(result)
    assert chart.title.startswith("Relative fit only")
    assert all(bar.color == MUTED for bar in chart.bars)
    explained = probability_chart(result | {"explained": True})
    assert explained.title == "Hypothesis probabilities"
    assert explained.bars[0].color == "#0072B2"


def test_the_leak_chart_draws_each_cycle_and_the_segments_medians() -> None:
    """Hand-made answer: five cycles, a step at the fourth; the leaking cycles apart from
    the others, the line at each segment's median leak (an even count averaged) [l/min],
    a marker line half a cycle before the step; a cycle not judged (NaN) is no point."""
    from app.console.charts import leak_chart
    from app.schemas.pump_leak import CycleLeakPublic, LeakShiftPublic, PumpLeakResponse

    flows = [1e-7, 3e-7, None, 5e-6, 7e-6]
    cycles = [CycleLeakPublic(series_id=i + 1, name=f"c{i}", measured_at=None,
                              oil_temperature=40.0, pressure=1.5e7, flow=1.2e-4,
                              deficit=f or 0.0, size=None if f is None else f / 3873.0,
                              leak_flow=f, leaking=i >= 3) for i, f in enumerate(flows)]
    answer = PumpLeakResponse(
        rig_id=2, rig_version=1, reference="batch", leaking=2, threshold=2e-6, slope=0.0,
        shunt=0.0, separation=9.0, relaxation=3.5, fitted_on=5, cycles=cycles,
        shifts=[LeakShiftPublic(index=3, series_id=4, name="c3", measured_at=None,
                                size_before=0.0, size_after=1.5e-9)], notes=[])
    chart = leak_chart(answer)
    quiet, loud, line = chart.series
    assert list(quiet.x) == [0.0, 1.0, 2.0] and list(loud.x) == [3.0, 4.0]
    assert np.isnan(quiet.y[2]) and list(loud.y) == pytest.approx([0.3, 0.42])
    assert list(line.x) == [0.0, 2.0, 3.0, 4.0]
    assert list(line.y) == pytest.approx([0.012, 0.012, 0.36, 0.36])  # (0.006 + 0.018)/2
    assert chart.vlines == ((2.5, "step"),)
    assert chart.ylabel == "leak at the plateau pressure [l/min]"
