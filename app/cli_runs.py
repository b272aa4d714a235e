"""The work commands: ``simulate``, ``diagnose FILE``, ``sweep FILE``, ``calibrate ...``.

Each calls the same service function as its route, on the store the service uses
(``HYDRODIAG_DATA_DIR`` / ``HYDRODIAG_DATABASE_URL``), and takes the same JSON (or YAML)
documents as the API bodies: ``diagnose`` a record, a list of records or a whole
``/diagnose`` body; ``sweep`` a ``/scenarios`` body; ``calibrate throttle`` a
``/rigs/{id}/calibrations`` body.  ``--json`` prints the API's answer.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.markup import escape
from rich.table import Column, Table

from app.cli_calibrate import calibrate_cli
from app.cli_import import import_cli
from app.cli_pump_map import calibrate_pump_map
from app.cli_support import (
    ColumnMapOption,
    SampleRateOption,
    WideWhenPiped,
    as_option,
    console,
    load_document,
    reading_options,
    series_ids,
    settings_from_env,
    shown_estimate,
    steps,
    store_id,
    store_session,
    validated,
    writable,
)
from sim.errors import HydrodiagError, InputError, NotFoundError
from sim.scenarios import fault_help
from sim.units import unit_suffix

if TYPE_CHECKING:
    from app.services.sweeps import SweepPlan

__all__ = ["register"]

_out = WideWhenPiped()


#: simulate: the request's fields → the options that fill them
_SIMULATE_OPTIONS = {"rig_id": "--rig", "fault": "--fault", "sample_rate": "--sample-rate",
                     "timeseries": "--output", "rtol": "--rtol", "solver": "--solver",
                     "condition.load": "--load", "condition.back_pressure": "--back-pressure",
                     "condition.oil_temperature": "--oil-temperature",
                     "condition.pump_speed": "--pump-speed", "overrides": "--set *"}


#: commission: the request's fields → the options that fill them
_COMMISSION_OPTIONS = {"parameters": "--parameter", "rig_id": "--rig",
                       "beyond_prior": "--beyond-prior"}


def _print_json(payload: Any) -> None:
    typer.echo(json.dumps(payload, indent=2, default=str))


def _overrides(items: list[str], *, field: str = "--set", form: str = "role.name=value"
               ) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items:
        name, _, value = item.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise InputError(f"expected {form}, got {item!r}", field=field) from None
    return out


def simulate(
    rig_id: Annotated[int, typer.Option("--rig", parser=store_id,
                                        help="Rig id in the store.")] = 1,
    fault: Annotated[str | None, typer.Option(help=f"Named fault: {fault_help()}.")] = None,
    set_: Annotated[list[str] | None, typer.Option(
        "--set", help="Override role.name=value in SI units (repeat), e.g. valve.cv=60e-6.")
    ] = None,
    load: Annotated[float | None, typer.Option(help="Load force \\[N].")] = None,
    back_pressure: Annotated[float | None, typer.Option(help="Back-pressure \\[Pa].")] = None,
    oil_temperature: Annotated[float | None, typer.Option(help="Oil temperature \\[°C].")] = None,
    pump_speed: Annotated[float | None, typer.Option(help="Pump speed \\[rad/s].")] = None,
    steady: Annotated[bool, typer.Option(help="Steady operating points only (fast).")] = False,
    solver: Annotated[str, typer.Option(help="Integrator: rodas4 or ros2.")] = "rodas4",
    rtol: Annotated[float | None, typer.Option(
        help="Relative tolerance; default: noise-accurate (error below 0.3σ velocity, "
        "0.1σ pressure and flow).")] = None,
    sample_rate: Annotated[float | None, typer.Option(
        help="Time series on a grid of this rate [Hz] (rodas4); default one row per "
        "solver step.")] = None,
    output: Annotated[Path | None, typer.Option(
        help="Write the time series here: .csv, .parquet or .json.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the API's JSON answer.")] = False,
) -> None:
    """Simulate a fault scenario on a stored rig and print the phase summary."""
    from app.schemas.simulate import SimulateRequest
    from app.services.rig_cache import RigCache
    from app.services.simulation import (
        public_of,
        timeseries_csv,
        timeseries_parquet,
    )
    from app.services.simulation import (
        simulate as run,
    )

    formats = {".csv": "csv", ".parquet": "parquet", ".json": "json"}
    if output is not None and output.suffix.lower() not in formats:
        raise InputError("the output must end in .csv, .parquet or .json", field="--output")
    if output is not None:
        writable(output, "--output")
    request = validated(SimulateRequest, {
        "rig_id": rig_id, "fault": fault, "overrides": _overrides(set_ or []),
        "condition": {"load": load, "back_pressure": back_pressure,
                      "oil_temperature": oil_temperature, "pump_speed": pump_speed},
        "method": "steady" if steady else "transient",
        "timeseries": formats[output.suffix.lower()] if output is not None else None,
        "solver": solver, "rtol": rtol, "sample_rate": sample_rate,
    }, _SIMULATE_OPTIONS)
    with store_session() as session, steps() as progress:
        progress.add_task("simulating", total=None)
        try:
            outcome = run(session, RigCache(1), request)
        except HydrodiagError as exc:
            raise as_option(exc, _SIMULATE_OPTIONS) from None
    if output is not None:
        kind = formats[output.suffix.lower()]
        if kind == "csv":
            output.write_bytes(timeseries_csv(outcome))
        elif kind == "parquet":
            output.write_bytes(timeseries_parquet(outcome))
        else:
            output.write_text(public_of(outcome, table=True).model_dump_json(indent=2),
                              encoding="utf-8")
        console.print(f"time series written to {output}")
    public = public_of(outcome)
    if as_json:
        _print_json(public.model_dump(mode="json"))
        return
    table = Table("quantity", "value", title=f"rig {public.rig_id} v{public.rig_version}, "
                  f"{public.fault or ('overrides only' if set_ else 'nominal')}, {public.method}")
    for key, value in public.summary.items():
        table.add_row(escape(key), "—" if value is None else f"{value:.6g}")
    if public.solver is not None:
        table.add_row("solver", f"{public.solver.method}, rtol {public.solver.rtol:.3g}")
        for name, err in (public.solver.error_sigma or {}).items():
            table.add_row(escape(f"error estimate {name} [σ]"), f"{err:.3g}")
    _out.print(table)
    for note in public.notes:
        console.print(f"[yellow]note:[/yellow] {escape(note)}")


def _diagnose_body(document: Any, *, joint: bool, store: bool) -> dict[str, Any]:
    if isinstance(document, list):
        return {"records": document, "joint": joint, "store": store}
    if isinstance(document, dict) and ("record" in document or "records" in document):
        return {**document, "store": store and document.get("store", True),
                "joint": joint or document.get("joint", False)}
    return {"record": document, "store": store}


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
    stated = _overrides(condition or [], field="--condition", form="name=value")
    # the file is read and checked before the store is opened: a missing or bad file made
    # a new store in the current folder first, then was refused (a CLI pass)
    if not cycles:
        request = validated(DiagnoseRequest, _diagnose_body(load_document(str(file)),
                                                            joint=joint, store=store))
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
                joint=joint, store=store))
        task = progress.add_task("diagnosing", total=None)
        now = utcnow()
        response = response_of(request, diagnose_request(session, rigs, request, now), now)
        progress.update(task, description="done")
    if as_json:
        for note in file_notes:  # beside the JSON, which holds the diagnoses alone
            console.print(f"{file}: {note}", markup=False)
        _print_json(response.model_dump(mode="json"))
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


def commission(
    file: Annotated[str, typer.Argument(help="Healthy records: a list, or {records: [...]}, "
                                        "JSON or YAML.")],
    rig: Annotated[int, typer.Option(parser=store_id,
                                     help="Rig to commission (its latest version).")],
    parameter: Annotated[list[str] | None, typer.Option(
        help="A parameter to fit (repeat); all six by default.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the API's JSON answer.")] = False,
    beyond_prior: Annotated[bool, typer.Option(
        "--beyond-prior",
        help="Store a fit that moves a parameter more than 3 prior σ from the document's "
        "value (refused otherwise: the records may hold wear the fit would absorb).")] = False,
) -> None:
    """Fit rig RIG's uncertain parameters to FILE's healthy records and store the result as
    a new rig version, as POST /rigs/{id}/commission does."""
    from app.schemas.commission import CommissionRequest
    from app.services.commissioning import commission_rig
    from app.services.rig_cache import RigCache

    document = load_document(file)
    if isinstance(document, dict) and "records" in document:
        body = dict(document)
    elif isinstance(document, list):
        body = {"records": document}
    else:
        raise InputError(f"{file} holds no records: give a list of records, or "
                         "{records: [...]}", field="FILE")
    if parameter:
        body["parameters"] = parameter
    if beyond_prior:
        body["beyond_prior"] = True
    request = validated(CommissionRequest, body, _COMMISSION_OPTIONS)
    with store_session() as session, steps() as progress:
        task = progress.add_task("commissioning", total=None)
        try:
            response = commission_rig(session, RigCache(4), rig, request)
        except HydrodiagError as exc:
            raise as_option(exc, _COMMISSION_OPTIONS) from None
        progress.update(task, description="done")
    if as_json:
        _print_json(response.model_dump(mode="json"))
        return
    table = Table("parameter", Column("unit", overflow="fold"), "before", "fitted",
                  "95 % interval", "pinned down",
                  title=f"rig {response.rig_id}: version {response.from_version} → "
                  + (f"{response.version}" if response.stored else "nothing stored")
                  + f" (χ² = {response.chi2:.3g} on {response.n_observations} "
                  f"readings, {response.dof:.1f} degrees of freedom, limit "
                  f"{'none' if response.chi2_limit is None else f'{response.chi2_limit:.3g}'})")
    for p in response.parameters:
        # one unit column for before, fitted and interval (the fitted had none)
        table.add_row(escape(p.name), escape(p.unit), f"{p.before:.4g}", f"{p.value:.4g}",
                      f"{p.low:.4g} … {p.high:.4g}", "yes" if p.identifiable else "no")
    _out.print(table)
    for s in response.statements:
        _out.print(f"note: {s}", markup=False)


def sweep(
    file: Annotated[str, typer.Argument(help="Sweep: the body of POST /scenarios, JSON or YAML.")],
    output: Annotated[Path, typer.Option(help="Results: .csv or .json.")] = Path("sweep.csv"),
) -> None:
    """Run a sweep over fault scenarios with a progress bar; write the results table."""
    from app.schemas.sweeps import SweepRequest
    from app.services.executors import SweepExecutors
    from app.services.rig_cache import RigCache
    from app.services.sweeps import plan_sweep, run_sweep

    if output.suffix.lower() not in (".csv", ".json"):
        raise InputError("the output must end in .csv or .json", field="--output")
    writable(output, "--output")
    request = validated(SweepRequest, load_document(file))
    settings = settings_from_env()
    with store_session() as session:
        plan = plan_sweep(session, RigCache(1), request, settings.sweep_points)
    executors = SweepExecutors(workers=settings.sweep_workers,
                               dask_scheduler=settings.dask_scheduler)
    try:
        with steps() as progress:
            task = progress.add_task(f"{len(plan.points)} scenarios on {executors.kind}",
                                     total=1.0)
            result = run_sweep(plan, executors.get(),
                               lambda done, note: progress.update(task, completed=done),
                               executors.waiting())
    finally:
        executors.shutdown()
    if output.suffix.lower() == ".json":
        output.write_text(json.dumps(result, indent=1), encoding="utf-8")
    else:
        import pandas as pd

        pd.DataFrame(result["rows"], columns=_with_units(result["columns"], plan)
                     ).to_csv(output, index=False)
    console.print(f"{result['n_points']} scenarios, {result['n_failed']} failed: {output}")


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


def _with_units(columns: list[str], plan: SweepPlan) -> list[str]:
    """The sweep's columns with each factor's SI unit, as its summary columns have theirs
    (``cylinder.cc [m]``, ``condition.load [N]``; the factors had none: a CLI pass)."""
    from app.schemas.sweeps import CONDITION_NAMES

    declared = plan.resolved.rig.model.system.graph.parameters
    out = []
    for c in columns:
        if c in plan.factors:
            role, _, name = c.partition(".")
            unit = (CONDITION_NAMES.get(name) if role == "condition" else
                    getattr(declared.get(c), "unit", None))
            c = f"{c} [{unit}]" if unit else c
        out.append(c)
    return out


def register(cli: typer.Typer) -> None:
    """Add the work commands to the ``hydrodiag`` command."""
    cli.command()(simulate)
    cli.command()(diagnose)
    cli.command()(commission)
    cli.command()(sweep)
    calibrate_cli.command("pump-map")(calibrate_pump_map)
    cli.add_typer(calibrate_cli, name="calibrate")
    cli.add_typer(import_cli, name="import")


def _parameter_text(p: dict[str, Any]) -> str:
    """``name = value (low … high) unit`` of a fitted parameter (no unit for a factor,
    whose unit is 1), and whether the fit sits on the healthy end of the hypothesis's worn
    range (the records show no more wear than the hypothesis must assume)."""
    value, interval, unit = shown_estimate(p["value"], p["low"], p["high"], p["unit"])
    bound = ", at bound" if p.get("at_bound") else ""
    return f"{p['name']} = {value} ({interval}){unit_suffix(unit)}{bound}"
