"""``hydrodiag diagnose``: records (JSON or YAML), measured cycles (CSV or Parquet, with
``--rig``) or stored cycles (``--series``) diagnosed against their stored rig, as ``POST
/diagnose`` does, printed as a table per diagnosis (``--json``: the API's answer)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.table import Table

from app.cli_share import CalibrationShareOption, state_share
from app.cli_support import (
    ColumnMapOption,
    SampleRateOption,
    WideWhenPiped,
    console,
    load_document,
    name_values,
    print_json,
    reading_options,
    series_ids,
    shown_estimate,
    steps,
    store_id,
    store_session,
    validated,
)
from sim.errors import HydrodiagError, InputError, NotFoundError
from sim.units import unit_suffix

__all__ = ["diagnose"]

_out = WideWhenPiped()


def _diagnose_body(document: Any, *, joint: bool, store: bool,
                   share: float | None = None) -> dict[str, Any]:
    if isinstance(document, list):
        body = {"records": document, "joint": joint, "store": store}
    elif isinstance(document, dict) and ("record" in document or "records" in document):
        body = {**document, "store": store and document.get("store", True),
                "joint": joint or document.get("joint", False)}
    else:
        body = {"record": document, "store": store}
    for key in ("record", "records"):
        state_share(body.get(key), share)
    return body


#: suffixes of a measured cycle's file, gzip-compressed or not (the import path of
#: diagnostics.timeseries: CSV separated by commas, semicolons or tabs, or Parquet)
_CYCLE_SUFFIXES = (".csv", ".tsv", ".txt", ".parquet", ".pq")


def _is_cycle_file(name: str) -> bool:
    """Whether ``name`` is a measured cycle's table (``run.csv``, ``log.txt.gz``)."""
    return Path(name.removesuffix(".gz")).suffix.lower() in _CYCLE_SUFFIXES


def diagnose(
    file: Annotated[str | None, typer.Argument(
        help="Record(s): JSON or YAML (a record, a list, or a /diagnose body); or measured "
        "cycles: CSV (.csv, .tsv, .txt) or Parquet, gzip-compressed or not, in the /simulate "
        "export's format or a logger's through --column-map, with --rig.")] = None,
    series: Annotated[str | None, typer.Option(
        help="Stored measured cycles (POST /rigs/{id}/series) instead of FILE: ids, "
        "comma-separated, e.g. 3,4.")] = None,
    rig: Annotated[int | None, typer.Option(parser=store_id,
                                            help="The rig a cycle FILE was measured on.")
                   ] = None,
    condition: Annotated[list[str] | None, typer.Option(
        help="A cycle's condition where its file does not state it or is wrong: "
        "oil_temperature=40 (°C), load_force=4200 (N), back_pressure (Pa), pump_speed "
        "(rad/s); repeat.")] = None,
    column_map: ColumnMapOption = None,
    sample_rate: SampleRateOption = None,
    started_at: Annotated[str | None, typer.Option(
        help="Clock time at which a cycle FILE's t reads 0, ISO 8601 with zone \\[UTC]: the "
        "records are diagnosed as measured then.")] = None,
    joint: Annotated[bool, typer.Option(help="Diagnose all records together.")] = False,
    calibration_share: CalibrationShareOption = None,
    store: Annotated[bool, typer.Option(help="Keep records and results in the history.")
                     ] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print the API's JSON answer.")] = False,
) -> None:
    """Diagnose the record(s) of FILE, or measured cycles, against their stored rig, as POST
    /diagnose does.

    A measured cycle (a CSV or Parquet FILE with --rig, or stored cycles by --series) is
    read as the rig's meters read it, as GET /series/{id}/record does: working-phase
    pressures and flows over the middle 80 % of the travel, each stroke's steady speed.
    A logger's file is read through --column-map (and --sample-rate, --started-at) as
    'import series' reads it.
    """
    from app.db.base import utcnow
    from app.schemas.diagnose import DiagnoseRequest
    from app.services.diagnosis import diagnose_request
    from app.services.diagnosis_response import response_of
    from app.services.rig_cache import RigCache
    from app.services.series_record import file_cycle_records
    from diagnostics.diagnose import BLIND_NOTE

    if (file is None) == (series is None):
        raise InputError("give FILE or --series (stored cycles), one of them", field="FILE")
    cycles = series is not None or _is_cycle_file(str(file))
    if not cycles and (rig is not None or condition):
        raise InputError("--rig and --condition go with a measured cycle (CSV or Parquet, or "
                         "--series); a JSON or YAML record names its rig itself", field="--rig")
    reading = {"--column-map": column_map, "--sample-rate": sample_rate,
               "--started-at": started_at}
    for option, value in reading.items():
        if value is not None and (series is not None or not cycles):
            raise InputError(f"{option} goes with a cycle FILE (CSV or Parquet); stored "
                             "cycles were read at import", field=option)
    cmap, sample_rate, start = reading_options(column_map, sample_rate, started_at)
    stated = name_values(condition or [], field="--condition", form="name=value")
    # the file is read and checked before the store is opened: a missing or bad file made
    # a new store in the current folder first, then was refused (a CLI pass)
    if not cycles:
        request = validated(DiagnoseRequest, _diagnose_body(
            load_document(str(file)), joint=joint, store=store, share=calibration_share))
    elif file is not None and not Path(file).is_file():
        raise InputError(f"cannot read {file}: no such file", field="FILE")
    with store_session() as session, steps() as progress:
        rigs = RigCache(4)
        file_notes: list[str] = []
        if series is not None:
            read = [_series_read(session, rigs, i, stated) for i in series_ids(series)]
        elif cycles:
            if rig is None:
                raise InputError("a measured cycle needs the rig it was measured on (--rig ID)",
                                 field="--rig")
            read, file_notes = file_cycle_records(
                session, rigs, Path(str(file)), rig, condition=stated, column_map=cmap,
                sample_rate=sample_rate, started_at=start)
        if cycles:
            request = validated(DiagnoseRequest, _diagnose_body(
                [r.body for r in read] if joint or len(read) > 1 else read[0].body,
                joint=joint, store=store, share=calibration_share))
        task = progress.add_task("diagnosing", total=None)
        now = utcnow()
        response = response_of(request, diagnose_request(session, rigs, request, now), now)
        progress.update(task, description="done")
    if as_json:
        for note in file_notes:  # beside the JSON, which holds the diagnoses alone
            console.print(f"{file}: {note}", markup=False)
        print_json(response.model_dump(mode="json"))
        return
    if cycles:
        for note in file_notes:
            _out.print(f"{file}: {note}", markup=False)
        for k, r in enumerate(read):
            # a channel the cycles do not read is said once, for the file
            for note in (n for n in r.readings.notes if n not in file_notes):
                _out.print(f"cycle {r.readings.name} (record {k}): {note}", markup=False)
    for item in response.diagnoses:
        table = Table("hypothesis", "probability", "parameters (95 % interval)",
                      title=f"{', '.join(item.records)}: {item.top} "
                      f"(p = {item.probability:.3f}), diagnosis {item.id or 'not stored'}")
        for fit in item.result["hypotheses"]:
            # a value the readings do not feel is no finding (a relief "at 21 bar" on a 70
            # bar valve read as one: a user pass); the isolability statements say why
            params = ", ".join(_parameter_text(p) for p in fit["parameters"]) if \
                fit["observable"] else "— (these readings do not feel it)"
            probability = "not observable" if not fit["observable"] else \
                f"{fit['probability']:.4f}"
            table.add_row(escape(fit["name"]), probability, escape(params))
        _out.print(table)
        if any(p.get("at_bound") for f in item.result["hypotheses"] for p in f["parameters"]):
            _out.print("at bound: the fit sits on the healthy end of the hypothesis's worn "
                       "range (the records show no more wear than it must assume)", markup=False)
        notes = list(item.result.get("notes") or [])
        if item.misfit:
            _out.print(f"[bold red]not explained:[/] {escape(item.misfit)}")
        elif BLIND_NOTE in notes:
            # "healthy (p = 1.000)" and "consistent with healthy" where nothing could be
            # seen (a verification pass)
            _out.print(f"[bold yellow]caution:[/] {escape(BLIND_NOTE)}")
            notes.remove(BLIND_NOTE)
        elif item.result.get("confident") is False and item.goodness_of_fit is not None:
            # explained, but not a confident name: a fault beyond the prior ranges fits as
            # well, the fit lies below its worn range (incipient), or no χ² test is possible
            _out.print("[bold yellow]caution:[/] "
                       f"{escape(item.goodness_of_fit.statement)}")
        elif item.result.get("isolated") is False:
            # explained and confident, but the name's components do not hold 95 % alone
            cred = item.result["isolability"]["credible_set"]
            _out.print(f"not isolated: {', '.join(cred)} share 95 % of the probability",
                       markup=False)
            for statement in item.result["isolability"].get("statements", []):
                if " vs " in statement:  # the sensor (or test) that would separate them
                    _out.print(f"  {statement}", markup=False)
        for note in [*notes, *item.regime_notes]:  # the diagnosis's own notes were not shown
            _out.print(f"note: {note}", markup=False)
    for note in response.notes:
        _out.print(f"note: {note}", markup=False)


def _series_read(session: Any, rigs: Any, series_id: int, condition: dict[str, float]) -> Any:
    """Stored cycle ``series_id`` read as a record; a refusal says which of the series it
    was (``diagnose --series 1,2`` said "p1: gauge pressure 2.2e11 Pa" of series 2 alone:
    a CLI pass)."""
    from app.services.series_record import stored_cycle_record

    try:
        return stored_cycle_record(session, rigs, series_id, condition=condition)
    except NotFoundError:
        raise   # "no series with id 99" says it
    except HydrodiagError as exc:
        raise type(exc)(f"series {series_id}: {exc.message}", field=exc.field) from None


def _parameter_text(p: dict[str, Any]) -> str:
    """``name = value (low … high) unit`` of a fitted parameter (no unit for a factor,
    whose unit is 1), and whether the fit sits on the healthy end of the hypothesis's worn
    range (the records show no more wear than the hypothesis must assume)."""
    value, interval, unit = shown_estimate(p["value"], p["low"], p["high"], p["unit"])
    bound = ", at bound" if p.get("at_bound") else ""
    return f"{p['name']} = {value} ({interval}){unit_suffix(unit)}{bound}"
