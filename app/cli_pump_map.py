"""``hydrodiag calibrate pump-map FILE``: a manufacturer's efficiency map, one pump set per
displacement setting.

An efficiency map in the V32HL56 layout (``../shared/data/real/pump-efficiency-V32HL56``:
``Speed`` [rpm], ``Torque`` [N·m], ``Deltap`` [MPa], ``QOut`` [l/min], ``Displacement``
[cm³/rev]; :func:`diagnostics.pump.piston.read_efficiency_map`) holds several displacement
settings of a variable pump and no oil temperature.  Each setting becomes a bench table in
the pump-bench CSV format (:func:`diagnostics.pump.piston.bench_frame`, at the oil
temperature the user states) and goes through what ``hydrodiag calibrate pump`` and
``POST /pump-sets/bench`` do: Toet's derived capacity, the single-temperature mode, the
sign-checked loss model with one speed left out.  Every setting is parameterised and every
name checked before anything is stored (a bad setting stores none).  ``--bench-dir``
writes the tables, which ``hydrodiag discover TABLE --rig ID`` takes as they are.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from pydantic import ValidationError
from rich.markup import escape
from rich.table import Table

from app.cli_support import WideWhenPiped, steps, store_id, store_session, validation_error
from sim.errors import InputError
from sim.units import from_si

if TYPE_CHECKING:
    from app.schemas.pumps import PumpSetCreate

__all__ = ["calibrate_pump_map"]

_out = WideWhenPiped()

def _tables(file: Path, theta: float) -> list[tuple[float, bytes, int, int]]:
    """(setting [cm³/rev], bench CSV bytes, points, speeds) of every displacement setting."""
    from diagnostics.pump.levels import cluster_levels
    from diagnostics.pump.piston import bench_frame, read_efficiency_map

    if not file.is_file():
        raise InputError(f"no such file: {file}", field="FILE")
    data = read_efficiency_map(file)
    label, levels = cluster_levels(data.D, field="Displacement")
    out = []
    for i, level in enumerate(levels):
        part = data.subset(label == i)
        speeds = cluster_levels(part.omega, field="Speed")[1].size
        cm3 = from_si(float(level), "cm^3/rev", "m^3/rad")
        drain = ("; its case-drain flow QDr is not carried (the bench format has none: q is "
                 "the delivered flow QOut)" if part.q_drain is not None else "")
        head = (f"# efficiency map {file.name}, displacement setting {cm3:.1f} cm3/rev; "
                f"oil temperature {theta:g} degC assumed (the map records none){drain}\n")
        body = bench_frame(part, theta).to_csv(index=False)
        out.append((cm3, (head + body).encode(), len(part), speeds))
    return out


def _write(tables: list[tuple[float, bytes, int, int]], file: Path, folder: Path | None
           ) -> None:
    """Each setting's bench table as ``<map>-<setting>cm3.csv`` in ``folder`` (if given)."""
    if folder is None:
        return
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for cm3, content, _, _ in tables:
            (folder / f"{file.stem}-{cm3:.1f}cm3.csv").write_bytes(content)
    except OSError as exc:
        raise InputError(f"cannot write into {folder}: {exc.strerror}",
                         field="--bench-dir") from None


def _shown(pump_set: PumpSetCreate, key: str, scale: float = 1.0) -> str:
    """The quantity ``key`` of a pump set × ``scale``, or "-" where it has none."""
    q = pump_set.quantities.get(key)
    v = None if q is None else q.value
    return f"{float(v) * scale:.3f}" if isinstance(v, float) and math.isfinite(v) else "-"


def calibrate_pump_map(
    file: Annotated[Path, typer.Argument(help="Efficiency map in the V32HL56 layout: Speed "
                                         "\\[rpm], Torque \\[N*m], Deltap \\[MPa], QOut "
                                         "\\[l/min], Displacement \\[cm³/rev].")],
    name: Annotated[str, typer.Option(help="Name prefix of the pump sets, one per setting: "
                                      "NAME-56.9cm3.")],
    pump: Annotated[str, typer.Option(help="Pump model and size.")],
    theta: Annotated[float, typer.Option(help="Oil temperature \\[°C] assumed for the "
                                         "whole map (the file records none).",
                                         min=-40.0, max=150.0)],
    rig_id: Annotated[int | None, typer.Option("--rig", parser=store_id,
                                               help="Rig of the pump.")] = None,
    bench_dir: Annotated[Path | None, typer.Option(
        help="Write each setting's bench table (pump-bench CSV) into this folder.")] = None,
    store: Annotated[bool, typer.Option(help="Store the pump sets.")] = True,
) -> None:
    """Parameterise every displacement setting of an efficiency map; one pump set each.

    Each setting is a bench table at the stated oil temperature: Toet's derived capacity,
    the two-temperature coefficients marked not identifiable, the sign-checked loss model
    checked with one speed left out (check_flow_S, check_torque_S \\[%] of the setting's
    largest flow and torque).  Nothing is stored when any setting fails.
    """
    from app.schemas.pumps import PumpBenchForm
    from app.services.pump_bench import bench_pump_set
    from app.services.pumps import check_name_free, create_pump_set
    from app.services.rigs import get_rig

    tables = _tables(file, theta)
    sets: list[PumpSetCreate] = []
    with steps() as progress:
        task = progress.add_task("parameterising settings", total=len(tables))
        for cm3, content, _, _ in tables:
            try:
                form = PumpBenchForm.model_validate({
                    "name": f"{name}-{cm3:.1f}cm3", "pump": f"{pump} at {cm3:.1f} cm³/rev",
                    "rig_id": rig_id})   # the table's header line is the set's source
            except ValidationError as exc:
                bad = validation_error(exc)
                raise InputError(bad.message, field=f"--{bad.field}") from None
            try:
                sets.append(bench_pump_set(form, content))
            except InputError as exc:
                raise InputError(f"setting {cm3:.1f} cm³/rev: {exc.message}",
                                 field=exc.field) from None
            progress.advance(task)
    ids: list[str] = ["-"] * len(sets)
    if store:
        with store_session() as session:
            if rig_id is not None:
                get_rig(session, rig_id, field="--rig")
            for s in sets:
                check_name_free(session, s.name)
            _write(tables, file, bench_dir)  # checked: nothing refused from here on
            ids = [str(create_pump_set(session, s).id) for s in sets]
    else:
        _write(tables, file, bench_dir)
    table = Table("setting \\[cm³/rev]", "points", "speeds", "D Toet \\[cm³/rev]",
                  "flow S \\[%]", "torque S \\[%]", "pump set",
                  title=escape(f"{file.name}: {len(sets)} displacement settings, θ "
                               f"{theta:g} °C assumed"))
    for (cm3, _, n, speeds), s, sid in zip(tables, sets, ids, strict=True):
        table.add_row(f"{cm3:.1f}", str(n), str(speeds), _shown(s, "D", from_si(1.0, "cm^3/rev", "m^3/rad")),
                      _shown(s, "check_flow_S"), _shown(s, "check_torque_S"), sid)
    _out.print(table)
    _out.print("S: RMS error with one speed left out at a time, % of the setting's largest "
               "measured flow or torque", markup=False)
    if bench_dir is not None:
        last = bench_dir / f"{file.stem}-{tables[-1][0]:.1f}cm3.csv"
        _out.print(f"bench tables in {bench_dir}; what a rig's pump model misses in one: "
                   f"hydrodiag discover {last} --rig ID", markup=False)
