"""``hydrodiag calibrate``: pump parameterisation from a bench CSV, throttle equivalence
tables (stored and listed); the commands of :mod:`app.cli_runs`' ``calibrate`` group."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.table import Table

from app.cli_support import WideWhenPiped, load_document, steps, store_id, store_session, validated
from diagnostics.plots import shown_unit
from sim.errors import InputError

__all__ = ["calibrate_cli"]

_out = WideWhenPiped()

calibrate_cli = typer.Typer(help="Pump parameterisation and throttle equivalence tables.",
                            no_args_is_help=True)


@calibrate_cli.command("pump")
def calibrate_pump(
    file: Annotated[Path, typer.Argument(help="Bench CSV, units in the column names.")],
    name: Annotated[str, typer.Option(help="Unique name of the pump set.")],
    pump: Annotated[str, typer.Option(help="Pump model and size.")],
    rig_id: Annotated[int | None, typer.Option("--rig", parser=store_id,
                                               help="Rig of the pump.")] = None,
    displacement: Annotated[float | None, typer.Option(
        help="Derived capacity D \\[m³/rad]; from the data when left out.")] = None,
    displacement_cm3_rev: Annotated[float | None, typer.Option(
        "--displacement-cm3-rev",
        help="Derived capacity as displacement per revolution \\[cm³/rev] (instead of "
             "--displacement).")] = None,
    oil_nu40: Annotated[float | None, typer.Option(
        "--oil-nu40", help="The bench oil's kinematic viscosity at 40 °C from its data "
        "sheet \\[cSt], with --oil-nu100; left out: the default ISO VG 46 HM oil (46 cSt). "
        "Cs and Cv scale with the viscosity assumed.")] = None,
    oil_nu100: Annotated[float | None, typer.Option(
        "--oil-nu100", help="The bench oil's kinematic viscosity at 100 °C \\[cSt]; left "
                            "out: the default oil's 6.8 cSt.")] = None,
    oil_rho15: Annotated[float | None, typer.Option(
        "--oil-rho15", help="The bench oil's density at 15 °C \\[kg/m³]; left out: "
                            "879.")] = None,
) -> None:
    """Parameterise a pump from a bench CSV and store it, as POST /pump-sets/bench does.

    The CSV has one row per steady point with the unit in every column name: p_in, p_out
    \\[Pa, kPa, bar, MPa], n \\[rev/s, Hz, rpm, rad/s], theta \\[degC, K], q \\[m^3/s,
    l/min, L/min, cm^3/s], optional T \\[N*m] and replicate \\[-] (repeated runs of a set
    point).  Data at one oil temperature give the derived capacity only (the loss
    coefficients of paper 000 eqs. 7-9, 17-19 need two temperatures).  With torque and three
    speeds or more, the sign-checked loss model is fitted at each oil temperature and checked
    with one speed left out; the set keeps it, its test points and its held-out error
    (check_flow_S, check_torque_S \\[%]).
    """
    from app.schemas.pumps import OIL_NU_MIN, PumpBenchForm
    from app.services.pump_bench import store_bench_parameters

    if displacement is not None and displacement_cm3_rev is not None:
        raise InputError("give --displacement or --displacement-cm3-rev, not both",
                         field="--displacement-cm3-rev")
    # errors name the option typed (they named --displacement for a --displacement-cm3-rev
    # and the form's displacement_m3_rad: a pump maker's pass)
    option = "--displacement"
    if displacement_cm3_rev is not None:
        displacement = displacement_cm3_rev * 1e-6 / (2.0 * math.pi)
        option = "--displacement-cm3-rev"
    cst = 1e-6  # m²/s per cSt: the data sheet's unit, SI in the form
    for value, typed in ((oil_nu40, "--oil-nu40"), (oil_nu100, "--oil-nu100")):
        if value is not None and not value * cst >= OIL_NU_MIN:
            # 4.6e-5 typed as m²/s was refused as "≥ 0.000002" in the form's SI (a
            # verification pass): say it in the option's unit
            raise InputError(f"{value:g} cSt is below {OIL_NU_MIN / cst:g} cSt, where ASTM "
                             "D341's Walther law starts: the option takes cSt (46 for a VG "
                             "46 at 40 °C), not m²/s", field=typed)
    form = validated(PumpBenchForm, {
        "name": name, "pump": pump, "rig_id": rig_id, "displacement_m3_rad": displacement,
        "oil_nu40_m2_s": None if oil_nu40 is None else oil_nu40 * cst,
        "oil_nu100_m2_s": None if oil_nu100 is None else oil_nu100 * cst,
        "oil_rho15_kg_m3": oil_rho15},
        {"name": "--name", "pump": "--pump", "rig_id": "--rig", "displacement_m3_rad": option,
         "oil_nu40_m2_s": "--oil-nu40", "oil_nu100_m2_s": "--oil-nu100",
         "oil_rho15_kg_m3": "--oil-rho15"})
    try:
        content = file.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read {file}: {exc.strerror}", field="FILE") from None
    with store_session() as session, steps() as progress:
        progress.add_task("parameterising", total=None)
        try:
            pump_set = store_bench_parameters(session, form, content)
        except InputError as exc:
            if exc.field != "displacement_m3_rad":
                raise
            raise type(exc)(exc.message, field=option) from None
    table = Table("quantity", "value", "unit",
                  title=escape(f"pump set {pump_set.id}: {pump_set.name}"))
    models = []
    for key, quantity in pump_set.quantities.items():
        value, unit = quantity["value"], quantity["unit"]
        # in the units an engineer reads (cm³/rev, bar, …: the console's); SI is stored
        factor, shown_as = shown_unit(unit)
        if isinstance(value, float):
            shown, unit = f"{value * factor:.6g}", shown_as
        elif key.endswith("_range") and len(value) == 2:
            shown, unit = f"{value[0] * factor:.4g} … {value[1] * factor:.4g}", shown_as
        elif (key.endswith("_coef") and len(value) <= 8
              and all(isinstance(v, float | int) for v in value)):
            # a loss model's coefficients, named below by its terms (they were "array 6
            # rows", the term names only in the JSON description)
            shown = ", ".join(f"{v:.4g}" for v in value)
            models.append(f"{key}: {quantity.get('description', '')}")
        else:
            shown = f"array {len(value)} rows"
        table.add_row(escape(key), shown, escape(unit))
    _out.print(table)
    for line in models:
        _out.print(line, markup=False)
    if pump_set.source:
        _out.print(pump_set.source, markup=False)


@calibrate_cli.command("throttle")
def calibrate_throttle(
    file: Annotated[str, typer.Argument(help="Table: the body of POST /rigs/{id}/calibrations.")],
    rig_id: Annotated[int, typer.Option("--rig", parser=store_id,
                                        help="Rig id in the store (required: a table stored "
                                             "on another rig's geometry is wrong).")],
) -> None:
    """Store a throttle equivalence table; clearances not given are computed from the flows."""
    from app.schemas.calibrations import CalibrationCreate
    from app.services.calibrations import create_calibration
    from app.services.throttle_estimator import ThrottleClearanceEstimator

    document = load_document(file)
    if not isinstance(document, dict):
        # a CSV read as YAML is one string: "Input should be a valid dictionary" (a pass)
        raise InputError(
            "a throttle table file is the JSON or YAML body of POST /rigs/{id}/calibrations "
            "(throttle, component, back_pressure_pa [Pa], temperature_c [°C], points: "
            "opening_turns, bypass_flow_m3s [m³/s], clearance_m [m] optional); a CSV table "
            "is not read: docs/diagnosis.md, 'Throttle tables'", field="FILE")
    data = validated(CalibrationCreate, document)
    with store_session() as session, steps() as progress:
        progress.add_task("computing clearances", total=None)
        calibration = create_calibration(session, rig_id, data,
                                         estimator=ThrottleClearanceEstimator())
        shown = _rows_table(calibration, rig_id)
    _out.print(shown)


def _rows_table(calibration: Any, rig_id: int) -> Table:
    """A table's rows: flows and clearances as the store keeps them (SI) and as a
    technician reads them."""
    table = Table("opening \\[turn]", "bypass flow \\[m³/s]", "\\[l/min]", "clearance \\[m]",
                  "\\[µm]", "origin",
                  title=f"calibration {calibration.id} of rig {rig_id}: throttle "
                  f"{escape(calibration.throttle)}, {calibration.component} at "
                  f"{calibration.back_pressure_pa / 1e5:g} bar, {calibration.temperature_c:g} °C")
    for p in calibration.points:
        clearance = p.clearance_m
        table.add_row(f"{p.opening_turns:g}", f"{p.bypass_flow_m3s:.4g}",
                      f"{p.bypass_flow_m3s * 6e4:.4g}",
                      "—" if clearance is None else f"{clearance:.4g}",
                      "—" if clearance is None else f"{clearance * 1e6:.1f}",
                      p.clearance_origin or "")
    return table


@calibrate_cli.command("tables")
def calibrate_tables(
    rig_id: Annotated[int, typer.Option("--rig", parser=store_id,
                                        help="Rig id in the store.")] = 1,
    table_id: Annotated[int | None, typer.Option(
        "--table", parser=store_id, help="Show this table's rows: opening, flow and "
        "clearance, each in SI and as a technician reads it.")] = None,
    refresh: Annotated[bool, typer.Option(
        "--refresh", help="With --table: compute its computed clearances again against the "
        "rig's latest version (a stale table), as PATCH with {} does.")] = False,
    delete: Annotated[bool, typer.Option(
        "--delete", help="With --table: delete the table and its rows.")] = False,
) -> None:
    """List a rig's throttle equivalence tables: condition, rows, clearances in µm, and
    whether their computed clearances are stale (from an older rig version; --table ID
    --refresh computes them again); --table ID: one table's rows."""
    from app.schemas.calibrations import CalibrationUpdate
    from app.services.calibrations import (
        delete_calibration,
        get_calibration,
        is_stale,
        list_calibrations,
        update_calibration,
    )
    from app.services.rigs import get_rig
    from app.services.throttle_estimator import ThrottleClearanceEstimator

    if (refresh or delete) and table_id is None:
        raise InputError("name the table: --table ID", field="--refresh" if refresh
                         else "--delete")
    if refresh and delete:
        raise InputError("--refresh or --delete, one of them", field="--delete")
    if delete:   # the refusals of a duplicate table said to delete it over HTTP alone
        with store_session() as session:
            delete_calibration(session, rig_id, int(table_id or 0))
        _out.print(f"deleted throttle table {table_id} of rig {rig_id}")
        return
    if table_id is not None:   # a technician could store a table but not read its rows back
        with store_session() as session:
            if refresh:
                calibration = update_calibration(session, rig_id, table_id,
                                                 CalibrationUpdate.model_validate({}),
                                                 estimator=ThrottleClearanceEstimator())
            else:
                calibration = get_calibration(session, rig_id, table_id)
            one = _rows_table(calibration, rig_id)
        _out.print(one)
        return
    with store_session() as session:
        latest = get_rig(session, rig_id).latest_version
        tables, _ = list_calibrations(session, rig_id, limit=1000, offset=0)
        rows = [(c.id, c.throttle, c.component, c.back_pressure_pa, c.temperature_c,
                 [p.clearance_m for p in c.points], c.rig_version, is_stale(c, latest))
                for c in tables]
    table = Table("id", "throttle", "component", "back-pressure \\[bar]", "oil \\[°C]",
                  "clearances \\[µm]", "computed with", title=f"throttle tables of rig {rig_id} "
                  f"(latest version {latest})")
    for key, throttle, component, bp, oil, clearances, version, stale in rows:
        shown = ", ".join("—" if c is None else f"{c * 1e6:.1f}" for c in clearances)
        made = "—" if version is None and not stale else (
            f"version {version if version is not None else '?'}" + (" (stale)" if stale else ""))
        table.add_row(str(key), escape(throttle), escape(component), f"{bp / 1e5:g}",
                      f"{oil:g}", shown, made)
    _out.print(table)
