"""``hydrodiag report``: a stored diagnosis or a rig's trends as an HTML page or a PNG.

The HTML file is the console's page body (same templates, same charts from
:mod:`app.console.views`) with the stylesheet inlined, so it opens anywhere and can be
attached to a work order; the PNG is the page's charts one below the other.
"""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, Any

import typer

from app.cli_support import (
    SinceOption,
    UntilOption,
    WideWhenPiped,
    console,
    store_id,
    store_session,
    writable,
)
from app.schemas.times import iso_utc
from sim.errors import InputError

__all__ = ["render_report", "report_cli"]

report_cli = typer.Typer(help="Reports with plots: HTML (as the console shows) or PNG.",
                         no_args_is_help=True)

_CSS = Path(__file__).parent / "console" / "static" / "console.css"

_out = WideWhenPiped()


def _suffix(output: Path, allowed: tuple[str, ...] = (".html", ".png")) -> str:
    suffix = output.suffix.lower()
    if suffix not in allowed:
        raise InputError(f"the output must end in {' or '.join(allowed)}, not "
                         f"{suffix or 'nothing'!r}", field="--output")
    writable(output, "--output")
    return suffix


def render_report(title: str, charts: list[Any], suffix: str, **context: Any) -> bytes:
    """The report as HTML (console templates, stylesheet inlined) or as one PNG of its charts.

    Raises
    ------
    InputError
        A PNG asked of a report without a chart.
    """
    from diagnostics.plots import render_png_stack

    if suffix == ".png":
        if not charts:
            raise InputError("nothing to plot: the report has no chart", field="--output")
        return render_png_stack(charts)
    from app.console.web import templates

    html = templates.get_template("report.html").render(
        title=title, css=_CSS.read_text(encoding="utf-8"),
        made_at=datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"), **context)
    return html.encode("utf-8")


@report_cli.command("diagnosis")
def report_diagnosis(
    diagnosis_id: Annotated[int, typer.Argument(parser=store_id, help="Stored diagnosis id.")],
    output: Annotated[Path, typer.Option(help="report.html or report.png")] = Path("report.html"),
) -> None:
    """A stored diagnosis: probabilities, measured vs predicted, estimates, isolability."""
    from app.console.views import diagnosis_view

    suffix = _suffix(output)
    with store_session() as session:
        view = diagnosis_view(session, diagnosis_id)
        content = render_report(f"Diagnosis {view.id}", view.charts, suffix, view=view)
    output.write_bytes(content)
    console.print(f"wrote {output} ({len(content)} bytes)")


@report_cli.command("trends")
def report_trends(
    rig: Annotated[int, typer.Option(parser=store_id, help="Rig id.")] = 1,
    output: Annotated[Path, typer.Option(
        help="trends.html, trends.png, or trends.csv (every point, for a spreadsheet)")] = Path(
        "trends.html"),
    component: Annotated[str | None, typer.Option(
        help="Only this component: cylinder, valve or pump.")] = None,
    threshold: Annotated[float | None, typer.Option(
        help="The component's threshold in SI: a clearance in m (60e-6), the pump's Cs in 1 "
        "(default: the 'severe' wear of the rig document's value).")] = None,
    since: SinceOption = None,
    until: UntilOption = None,
) -> None:
    """A rig's component trends: estimates over time, Theil–Sen line, threshold, time left;
    a summary table is printed either way.  --since the day a part was changed trends the
    new part alone."""
    from app.console.views import trend_views
    from app.schemas.times import SinceTime, UntilTime, filter_time
    from app.services.rig_cache import RigCache
    from app.services.trends import component_trends

    suffix = _suffix(output, (".html", ".png", ".csv"))
    window: dict[str, Any] = {"since": filter_time(since, SinceTime, "--since"),
                              "until": filter_time(until, UntilTime, "--until"),
                              "component": component, "threshold": threshold}
    with store_session() as session:
        try:
            if suffix == ".csv":
                trends = component_trends(session, RigCache(1), rig, **window)
                content = _points_csv(trends)
            else:
                views = trend_views(session, RigCache(1), rig, **window)
                trends = [v.trend for v in views if v.trend is not None]
                content = render_report(f"Trends of rig {rig}", [v.chart for v in views],
                                        suffix, views=views, rig_id=rig)
        except InputError as exc:  # the options by their names on the command line
            if exc.field in ("component", "threshold"):
                exc.field = f"--{exc.field}"
            raise
    output.write_bytes(content)
    _summary(rig, trends)
    console.print(f"wrote {output} ({len(content)} bytes)")


def _points_csv(trends: list[Any]) -> bytes:
    """Every point of every component: what a planner's spreadsheet takes (a planner found
    no export of the history or the trends)."""
    import csv
    import io

    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["component", "quantity", "unit", "measured_at", "value", "low_95",
                     "high_95", "probability", "diagnosis_id", "rig_version",
                     "threshold", "status", "slope_per_day", "time_left_days",
                     "crossing_at"])
    for t in trends:
        # each row carries its trend's forecast: the points alone made a planner redo the
        # fit in the spreadsheet (a reliability engineer's pass)
        forecast = [repr(t.threshold), t.status,
                    "" if t.slope is None else repr(t.slope * 86400.0),
                    "" if t.time_left_s is None else repr(t.time_left_s / 86400.0),
                    "" if t.crossing_at is None else iso_utc(t.crossing_at)]
        for p in t.points:
            writer.writerow([t.component, t.quantity, t.unit, iso_utc(p.measured_at),
                             repr(p.value), "" if p.low is None else repr(p.low),
                             "" if p.high is None else repr(p.high),
                             "" if p.probability is None else repr(p.probability),
                             p.diagnosis_id, p.rig_version, *forecast])
    return buffer.getvalue().encode("utf-8")


def _summary(rig: int, trends: list[Any]) -> None:
    """Status, wear rate, time left and any step of each component, as a table."""
    from rich.table import Table

    from app.services.trends import status_text
    from sim.units import quantity_text

    table = Table("component", "points", "status", "rate \\[per day]",
                  "threshold", "last visit \\[UTC]", "time left \\[day]", "step",
                  title=f"trends of rig {rig} (time left counted from the last visit)")
    for t in trends:
        # a stale trend forecasts nothing: no rate either
        rate = "—" if t.slope is None or t.status == "stale" else quantity_text(
            t.slope * 86400.0, f"{t.unit}/day" if t.unit == "m" else "1", 3)
        left = "—" if t.time_left_s is None else f"{t.time_left_s / 86400.0:.3g}"
        step = "" if t.step_at is None or t.step_size is None else (
            f"{'+' if t.step_size > 0 else ''}{quantity_text(t.step_size, t.unit, 3)} "
            f"around {t.step_at:%Y-%m-%d}")
        last = max((p.measured_at for p in t.points), default=None)
        table.add_row(t.component, str(t.points_total), status_text(t), rate,
                      quantity_text(t.threshold, t.unit if t.unit == "m" else "1", 4),
                      "—" if last is None else f"{last:%Y-%m-%d %H:%M}", left, step)
    _out.print(table)  # the command's answer: on stdout, as other commands' tables (a CLI pass)
