"""The work commands: ``simulate``, ``diagnose FILE`` (:mod:`app.cli_diagnose`), ``sweep FILE``,
``calibrate ...``.

Each calls the same service function as its route, on the store the service uses
(``HYDRODIAG_DATA_DIR`` / ``HYDRODIAG_DATABASE_URL``), and takes the same JSON (or YAML)
documents as the API bodies: ``diagnose`` a record, a list of records or a whole
``/diagnose`` body; ``sweep`` a ``/scenarios`` body; ``calibrate throttle`` a
``/rigs/{id}/calibrations`` body.  ``--json`` prints the API's answer.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape
from rich.table import Column, Table

from app.cli_calibrate import calibrate_cli
from app.cli_diagnose import diagnose
from app.cli_import import import_cli
from app.cli_pump_map import calibrate_pump_map
from app.cli_share import CalibrationShareOption, state_share
from app.cli_support import (
    WideWhenPiped,
    as_option,
    console,
    load_document,
    name_values,
    print_json,
    settings_from_env,
    steps,
    store_id,
    store_session,
    validated,
    writable,
)
from sim.errors import HydrodiagError, InputError
from sim.scenarios import fault_help

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
        "rig_id": rig_id, "fault": fault, "overrides": name_values(set_ or []),
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
        print_json(public.model_dump(mode="json"))
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
    calibration_share: CalibrationShareOption = None,
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
    state_share(body["records"], calibration_share)
    request = validated(CommissionRequest, body, _COMMISSION_OPTIONS)
    with store_session() as session, steps() as progress:
        task = progress.add_task("commissioning", total=None)
        try:
            response = commission_rig(session, RigCache(4), rig, request)
        except HydrodiagError as exc:
            raise as_option(exc, _COMMISSION_OPTIONS) from None
        progress.update(task, description="done")
    if as_json:
        print_json(response.model_dump(mode="json"))
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
