"""``hydrodiag discover DATA --rig ID --report out.html``: the discrepancy workflow from the
command line, on the store the service uses, with a progress bar.

Reads DATA (CSV or Parquet in the ``/simulate`` export format, or a steady table in the
pump-bench CSV format) or the rig's stored records named by ``--series``, runs
:func:`diagnostics.discrepancy.discover` (or
:func:`~diagnostics.discrepancy.steady.discover_steady`) against the stored rig, stores the
augmented rig as a new version when an effect is named (``--no-store`` to keep the store
unchanged),
prints the verdict, the named effects and each balance's candidates (minimum detectable
size and VIF), and writes the report (HTML page, and the charts as
PNG and SVG beside it).  Exit code 0 on any verdict; a bad file is exit code 1 with a
message naming the column.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from pydantic import ValidationError
from rich.markup import escape
from rich.table import Table

from app.cli_support import (
    ColumnMapOption,
    SampleRateOption,
    WideWhenPiped,
    console,
    estimate_text,
    reading_options,
    series_ids,
    shown_estimate,
    shown_scale,
    steps,
    store_id,
    store_session,
    validation_error,
    writable,
)
from diagnostics.real.relaxation import ZEMA_RELAXATION
from sim.errors import HydrodiagError, InputError

if TYPE_CHECKING:
    from diagnostics.discrepancy.drift import BaseDrift
    from diagnostics.discrepancy.selection import Selection

__all__ = ["candidate_table", "discover", "drift_table", "register"]

#: the verdict and its tables (the result) go to stdout; progress and notes to stderr
_out = WideWhenPiped()


def discover(
    data: Annotated[Path | None, typer.Argument(help="Measured cycles: CSV or Parquet in the "
                                                "/simulate export format, each record with its "
                                                "'load \\[N]' and 'oil_temperature \\[degC]' "
                                                "columns (or the export's header), or steady "
                                                "points in the pump-bench CSV format.")] = None,
    rig_id: Annotated[int, typer.Option("--rig", parser=store_id,
                                        help="Rig id in the store.")] = 1,
    version: Annotated[int | None, typer.Option(parser=store_id,
                                                help="Rig version (default: latest).")] = None,
    report: Annotated[Path | None, typer.Option(help="Write the HTML report here "
                                                "(charts as PNG/SVG beside it).")] = None,
    refit: Annotated[bool, typer.Option(help="Output-error re-fit by re-simulation.")] = True,
    store: Annotated[bool, typer.Option(help="Store the augmented rig as a new version.")
                     ] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print the JSON report.")] = False,
    series: Annotated[str | None, typer.Option(
        help="Stored measured records of the rig to check instead of DATA (hydrodiag import, "
             "POST /rigs/{id}/series): ids, comma-separated, e.g. 3,4,5.")] = None,
    column_map: ColumnMapOption = None,
    sample_rate: SampleRateOption = None,
    relaxation: Annotated[float, typer.Option(
        help="--series of a rig without a working/return cycle (the ZeMA rig): settling "
             r"time of each pressure plateau's flow \[s]; the settled plateaus are checked "
             "as a pump-bench table.")] = ZEMA_RELAXATION,
) -> None:
    """Find what the rig model misses in DATA, name it, add it to the rig, show the gap."""
    from app.schemas.discrepancy import DiscrepancyForm
    from app.services.discrepancy import data_field, plan_discrepancy, store_discovery
    from app.services.rig_cache import RigCache
    from diagnostics.discrepancy import discover as run
    from diagnostics.discrepancy.report import DRIFT_INTERVALS, stored_line, write_report
    from diagnostics.discrepancy.steady import discover_steady

    if (data is None) == (series is None):
        raise InputError("give DATA or --series (stored records of the rig), one of them",
                         field="data" if data is None else "--series")
    if report is not None:
        writable(report, "--report")
    cmap, sample_rate, _ = reading_options(column_map, sample_rate, None)  # names the options
    if (cmap or sample_rate) and data is None:
        raise InputError("a column map and a sample rate read DATA; stored records were read "
                         "with theirs at import", field="--column-map" if cmap else
                         "--sample-rate")
    content = None
    if data is not None:
        if not data.is_file():
            raise InputError(f"no such file: {data}", field="data")
        content = data.read_bytes()
    try:  # the form POST /discrepancy takes, planned as it plans it
        form = DiscrepancyForm(
            rig_id=rig_id, rig_version=version, refit=refit, store=store,
            relaxation=relaxation, column_map=column_map, sample_rate=sample_rate,
            series_ids=None if series is None else ",".join(str(i) for i in series_ids(series)))
    except ValidationError as exc:
        raise _as_option(validation_error(exc)) from None
    with store_session() as session:
        rigs = RigCache(1)   # the plan resolves the same version from it
        resolved = rigs.get(session, rig_id, version)
        try:
            with data_field("data" if data is not None else "--series",
                            ("file", "records", "series_ids")):
                plan = plan_discrepancy(session, rigs, form, content,
                                        data.name if data is not None else None)
        except HydrodiagError as exc:
            raise _as_option(exc) from None
        bench, records = plan.bench, plan.records
        with steps() as progress:
            task = progress.add_task("discrepancy workflow", total=1.0)

            def tick(fraction: float, what: str) -> None:
                progress.update(task, completed=fraction, description=what)

            with data_field("--series" if series is not None else "data"):
                if bench is not None:
                    d = discover_steady(dict(resolved.document), bench, progress=tick)
                else:
                    d = run(dict(resolved.document), records, progress=tick, refit=refit)
        new_version = not_stored = None
        if store:
            new_version, not_stored = store_discovery(session, rig_id, resolved.version, d)
    if report is not None:
        written = write_report(d, report, stored=stored_line(rig_id, resolved.version,
                                                             new_version, not_stored))
        console.print(f"report written to {written['html']} (+ {len(written['png'])} PNG, "
                      f"{len(written['svg'])} SVG)")
    if as_json:
        typer.echo(json.dumps(d.to_dict() | {"rig_id": rig_id,
                                             "rig_version": resolved.version,
                                             "new_rig_version": new_version,
                                             "not_stored": not_stored}, indent=2, default=str))
        return
    # the message of a named effect starts with the verdict ("named coulomb …")
    rest = d.message[len(d.verdict):] if d.message.startswith(d.verdict) else f": {d.message}"
    _out.print(f"[bold]{d.verdict}[/bold]{escape(rest)}")
    if d.named:
        table = Table("effect", "parameter", "value", "95 % interval", "plausible",
                      title=f"rig {rig_id}: new version {new_version}" if new_version
                      else f"rig {rig_id} (not stored)")
        for n in d.named:
            value, interval, unit = shown_estimate(n.value, *n.interval, n.unit)
            table.add_row(n.name, f"{n.parameter} \\[{unit}]", value, interval,
                          "yes" if n.plausible else "NO")
        _out.print(table)
    if not_stored:
        _out.print(not_stored, markup=False)
    if any(sel.vif for sel in d.selections):
        _out.print(candidate_table(d.selections))
    if d.base_drift is not None and d.base_drift.accepted:
        _out.print(drift_table(d.base_drift.parameters, d.base_drift.kept))
        _out.print(DRIFT_INTERVALS, markup=False)


#: form fields of POST /discrepancy → the options that fill them here
_OPTIONS = {"series_ids": "--series", "relaxation": "--relaxation", "rig_id": "--rig",
            "rig_version": "--version", "column_map": "--column-map",
            "sample_rate": "--sample-rate"}


def candidate_table(selections: Sequence[Selection]) -> Table:
    """Every balance's candidates: whether chosen, the minimum detectable RMS on this design
    (in the unit an engineer reads) and the VIF beside the base columns — reported, not
    filtered on (DISCREPANCY.md, "Pitfalls"); ``∞``: in the base columns' span."""
    from diagnostics.plots import shown_unit

    table = Table("balance", "candidate", "chosen", "minimum detectable RMS", "VIF",
                  title="candidates on this test design (VIF: reported, not filtered on)")
    for sel in selections:
        factor, unit = shown_unit(sel.unit)
        chosen = {t.effect for t in sel.chosen.terms} if sel.chosen else set()
        for name, v in sel.vif.items():
            md = sel.detectable.get(name, math.inf)
            table.add_row(sel.balance, name, "yes" if name in chosen else "",
                          f"{factor * md:.3g} {escape(unit)}" if math.isfinite(md)
                          else "not identifiable",
                          f"{v:.3g}" if math.isfinite(v) else "∞")
    return table


def drift_table(parameters: Sequence[BaseDrift], kept: Sequence[str]) -> Table:
    """The re-fitted base parameters as a table: stored, re-fitted, change and interval,
    a clearance in µm (:func:`~app.cli_support.shown_estimate`); ``kept``: those kept as
    stored."""
    table = Table("parameter", "stored", "re-fitted", "change", "95 % interval",
                  title="base drift (reported, not stored)")
    for b in parameters:
        factor, unit = shown_scale(b.unit, b.stored, b.value)
        value, ci = estimate_text(factor * b.value, *(factor * x for x in b.interval)) \
            if b.interval else (f"{factor * b.value:.4g}", "—")
        table.add_row(f"{b.parameter} \\[{unit}]", f"{factor * b.stored:.4g}", value,
                      f"{100 * b.change:+.3g} %" + ("" if b.significant else " n.s."), ci)
    for k in kept:
        table.add_row(k, "", "kept as stored", "", "")
    return table


def _as_option(exc: HydrodiagError) -> HydrodiagError:
    """``exc`` naming the option that fills its form field (``column_map.PA`` →
    ``--column-map.PA``)."""
    head, dot, rest = (exc.field or "").partition(".")
    if head in _OPTIONS:
        exc.field = _OPTIONS[head] + dot + rest
    return exc


def register(cli: typer.Typer) -> None:
    """Add ``discover`` to the ``hydrodiag`` command."""
    cli.command()(discover)
