"""``hydrodiag import series FILE`` and ``hydrodiag import zema``: measured time series into the store.

Both call the services of ``POST /rigs/{rig_id}/series`` (:mod:`app.services.series`) on the
configured store and show a progress bar; ``zema`` reads the ZeMA rig's 1 Hz files (or, with
``--native``, its few raw cycles at their native rates) through the documented adapter
(:mod:`diagnostics.real.zema`), and can write them as one series file in the import format
(``--table``: what ``POST /rigs/{id}/series`` takes over HTTP).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.table import Table

from app.cli_support import (
    ColumnMapOption,
    SampleRateOption,
    WideWhenPiped,
    counted,
    reading_options,
    steps,
    store_id,
    store_session,
)
from diagnostics.real.relaxation import MAX_RELAXATION, ZEMA_RELAXATION
from sim.errors import CircuitError, ConflictError, InputError

if TYPE_CHECKING:
    from sqlalchemy.orm import Session

    from diagnostics.timeseries import SeriesRecord

__all__ = ["import_cli"]

_out = WideWhenPiped()

import_cli = typer.Typer(help="Import measured time series as measurements of a rig.",
                         no_args_is_help=True)

RigOption = Annotated[int, typer.Option("--rig", parser=store_id, help="Rig id in the store.")]
NameOption = Annotated[str, typer.Option(help="Name of the import (file or campaign): 1 to 200 "
                                                  "letters, digits and _ . : -.")]


def _shown(name: str) -> str:
    """A file name as a terminal can print it: a byte that is not UTF-8 shown as '?'."""
    return name.encode("utf-8", errors="replace").decode("utf-8")


def _summary(rows: list[object], title: str) -> None:
    from app.db.models import MeasuredSeries

    table = Table("id", "record", "measured at \\[UTC]", "samples", "rate \\[Hz]",
                  "channels \\[SI unit]", title=title)
    for row in rows:
        assert isinstance(row, MeasuredSeries)
        rate = "-" if row.sample_rate is None else f"{row.sample_rate:.6g}"
        units = ", ".join(f"{k} [{u}]" for k, u in row.units.items())
        when = "-" if row.measured_at is None else f"{row.measured_at:%Y-%m-%d %H:%M:%S}"
        table.add_row(str(row.id), row.record, when, str(row.n_samples), rate,
                      units.replace("[", "\\["))
    _out.print(table)


@import_cli.command("series")
def import_series(
    files: Annotated[list[Path], typer.Argument(
        help="CSV (comma, semicolon or tab) or Parquet files, gzip-compressed or not: "
             "'t \\[s]' and 'name \\[unit]' columns, optional 'record' and 'phase'; several "
             "files (a logger's folder) are stored together or not at all.")],
    rig_id: RigOption,
    name: NameOption,
    column_map: ColumnMapOption = None,
    sample_rate: SampleRateOption = None,
    started_at: Annotated[str | None, typer.Option(
        help="Clock time at which the file's t reads 0, ISO 8601 with zone (e.g. "
             "2026-11-20T08:00Z): each record is stored as measured then plus its first "
             "sample's t \\[UTC]; default: the file header's started_at, else none. One "
             "file only: several take theirs from their headers or names.")] = None,
    time_in_name: Annotated[str | None, typer.Option(
        help="Each file's start as its logger wrote it into the name, a strptime format "
             "(e.g. '%m-%d-%Y-%I-%M-%S %p' for '…_9-10-2019-4-37-01 PM.txt'; %Y %y %m %d %H "
             "%I %M %S %f %j %p %b %z).")] = None,
    zone: Annotated[str | None, typer.Option(
        help="The time zone of --time-in-name when its format has no %z: Z, +02:00, "
             "-0400.")] = None,
) -> None:
    """Read time-series files and store each record, as POST /rigs/{id}/series does."""
    from app.services.rig_channels import column_of, rig_channels
    from app.services.series import store_records, upload_start
    from diagnostics.map_notes import unmatched_map_notes
    from diagnostics.sampling import sampling_notes
    from diagnostics.timeseries import read_series

    cmap, sample_rate, start = reading_options(column_map, sample_rate, started_at)
    options = ("--started-at", "--time-in-name", "--zone")
    if time_in_name is None or start is not None:  # the options' conflicts, before any file
        upload_start(None, start, time_in_name, zone, names=options)
    if start is not None and len(files) > 1:
        raise InputError("one start for several files would put their records at the same "
                         "time: give each file its '# started_at = ...' header line, or "
                         "import them one by one", field="--started-at")
    with store_session() as session, steps() as progress:
        channels = rig_channels(session, rig_id)   # a known channel: of its dimension
        task = progress.add_task("reading", total=len(files))
        records = []
        for k, file in enumerate(files):
            progress.update(task, description=f"reading {_shown(file.name)}", completed=k)
            try:
                own = upload_start(file.name, start, time_in_name, zone, names=options)
                read = read_series(file, column_map=cmap, sample_rate=sample_rate,
                                   started_at=own, expected=channels.units)
                try:
                    channels.check_plateaus(read)   # as the HTTP import (it stored bar as Pa)
                except InputError as exc:
                    raise InputError(exc.message, field=column_of(exc.field, cmap)) from None
                records.extend(read)
            except InputError as exc:  # which of the files, and its column
                raise type(exc)(f"{file}: {exc.message}",
                                field="FILE" if exc.field == "file" else exc.field) from None
        progress.update(task, description=f"storing {counted(len(records), 'record')}",
                        total=len(records), completed=0)
        rows = store_records(session, rig_id, name, records,
                             lambda done, total: progress.update(task, completed=done))
        notes = (unmatched_map_notes(cmap, records) + channels.notes(rows)
                 + channels.time_notes(records) + sampling_notes(records, sample_rate))
    what = _shown(files[0].name) if len(files) == 1 else f"{len(files)} files"
    _summary(list(rows), f"{counted(len(rows), 'record')} of {what} stored for rig {rig_id}")
    for note in notes:
        _out.print(f"note: {note}", markup=False)


@import_cli.command("zema")
def import_zema(
    rig_id: RigOption,
    name: NameOption = "zema",
    first: Annotated[int, typer.Option(help="First cycle (1-based).")] = 1,
    last: Annotated[int, typer.Option(help="Last cycle (1-based, included).")] = 2205,
    root: Annotated[Path | None, typer.Option(
        help="Folder of the ZeMA data set; default: the folder uci-hydraulic-zema in data/real of "
             "HYDRODIAG_SHARED, ../shared or /work/shared.")] = None,
    bench: Annotated[Path | None, typer.Option(
        help="Also write the cycles' settled working plateaus here as a pump-bench CSV "
             "for 'hydrodiag discover' (plateau pressure, the rig's pump speed, the "
             "cycle's oil temperature, FS1).")] = None,
    relaxation: Annotated[float, typer.Option(
        help="Plateau settling time of --bench \\[s] (found on the ZeMA cycles without "
             "labels).")] = ZEMA_RELAXATION,
    native: Annotated[bool, typer.Option(
        help="Read the raw cycles at their native rates (PS1, PS2, EPS1 at 100 Hz; FS1 at "
             "10 Hz and TS1 at 1 Hz held between readings) from the data set's "
             "fullres_samples/ (cycles 1967, 1092, 1469, 439, 1791, 1954, 753, 409, 1478, "
             "2038: those of --first..--last), instead of the 1 Hz means of every cycle.")
                      ] = False,
    table: Annotated[Path | None, typer.Option(
        help="Also write the cycles as one series file in the import format (.csv, .csv.gz "
             "or .parquet: a record column, t and every channel with its SI unit in the "
             "column name, the clock time of --started-at kept) that POST "
             "/rigs/{id}/series and 'hydrodiag import series' read as it is.")] = None,
    store: Annotated[bool, typer.Option(help="Store the cycles as series of the rig.")
                     ] = True,
    started_at: Annotated[str | None, typer.Option(
        help="Clock time at which cycle 1 started, ISO 8601 with zone (e.g. "
             "2026-11-20T08:00Z): cycle k is stored as measured (k − 1) × 60 s later, "
             "the data set's cycles following one another; default: no time.")] = None,
) -> None:
    """Import ZeMA load cycles (PS1, PS2, FS1, EPS1, TS1; 1 Hz, or the raw few at their
    native rates with --native) through the adapter."""
    import dataclasses
    from datetime import timedelta

    from app.services.series import store_records
    from diagnostics.real.zema import (
        CYCLE_S,
        FULLRES_FILE,
        load_1hz,
        load_fullres,
        read_records,
        zema_root,
    )
    from diagnostics.series_writer import write_series
    from diagnostics.timeseries import clock_time

    if last < first:
        raise InputError("last must not be before first", field="--last")
    if first < 1:
        raise InputError("cycles are numbered from 1", field="--first")
    if not 0 <= relaxation <= MAX_RELAXATION:  # NaN too
        raise InputError(f"the settling time must be 0 to {MAX_RELAXATION:g} [s], as discover "
                         "takes it", field="--relaxation")
    if not store and bench is None and table is None:
        raise InputError("nothing to do: --no-store without --bench or --table",
                         field="--no-store")
    if bench is not None and bench.suffix.lower() not in (".csv", ".txt"):
        # a bench table is CSV text: pb.xlsx was "written" as CSV (a CLI pass)
        raise InputError(f"the bench table is written as CSV: give a .csv name, not "
                         f"{bench.name!r}", field="--bench")
    start = None if started_at is None else clock_time(started_at, field="--started-at")
    if native:
        every = load_fullres((root or zema_root()) / FULLRES_FILE)
        data = every.between(first, last)
        if not data.cycles.size:
            raise InputError(f"no cycle at the native rate in {first}-{last} (the data set "
                             f"has {', '.join(map(str, sorted(every.cycles)))})",
                             field="--first")
    else:
        try:
            data, _ = load_1hz(root, cycles=list(range(first, last + 1)))
        except InputError as exc:
            if exc.field != "cycles":
                raise
            # the adapter's 'cycles' is no option of this command: name the one out of range
            raise InputError(exc.message, field="--last") from None
    with store_session() as session, steps() as progress:
        speed = _pump_speed(session, rig_id)
        task = progress.add_task("reading cycles", total=data.cycles.size)
        records = read_records(data, lambda done, total: progress.update(task,
                                                                          completed=done))
        if start is not None:  # consecutive cycles: a time axis for the trends of a campaign
            records = [dataclasses.replace(r, started_at=start + timedelta(
                seconds=CYCLE_S * (int(k) - 1))) for r, k in zip(records, data.cycles,
                                                                  strict=True)]
        if table is not None:
            try:
                rows_tabled = write_series(records, table)
            except InputError as exc:
                raise InputError(exc.message, field="--table") from None
        if bench is not None:
            plateaus = progress.add_task("plateaus", total=None)
            rows_written = _write_bench(records, speed, relaxation, bench,
                                        f"ZeMA cycles {first}-{last}")
            progress.update(plateaus, total=1, completed=1)
        if store:
            job = progress.add_task("storing", total=len(records))
            try:
                rows = store_records(session, rig_id, name, records,
                                     lambda done, total: progress.update(job, completed=done))
            except ConflictError as exc:  # the range overlaps cycles stored before
                raise ConflictError(
                    f"{exc.message}; the range {first}-{last} is refused whole, so import "
                    "only the cycles not stored yet (--first after the last one stored: "
                    "GET /rigs/{id}/series lists them)", field="--first") from None
    if store:
        _out.print(f"{counted(len(rows), 'ZeMA cycle')} stored for rig {rig_id} as {name!r} "
                   f"(series {rows[0].id}..{rows[-1].id})", markup=False)
    if table is not None:
        _out.print(f"{counted(len(records), 'cycle')} ({counted(rows_tabled, 'sample')} at "
                   f"{data.sample_rate:g} Hz) written to {table}", markup=False)
    if bench is not None:
        _out.print(f"{counted(rows_written, 'settled plateau')} of "
                   f"{counted(len(records), 'cycle')} written to "
                   f"{bench} (τ = {relaxation:g} s, pump speed {speed * 30 / math.pi:.0f} rpm "
                   f"from rig {rig_id})", markup=False)


def _pump_speed(session: Session, rig_id: int) -> float:
    """The stored rig's pump shaft speed [rad/s] (what the bench table records), once the
    rig is checked to be of the ZeMA circuit (:data:`diagnostics.real.zema.CIRCUIT`).

    Raises
    ------
    CircuitError
        A rig of another circuit (``field="--rig"``): ZeMA cycles stored on the paper-002
        rig, and a bench table written at its 1600 rpm, were once accepted silently.
    """
    from app.services.rigs import get_rig, latest_version
    from diagnostics.real.profile import stated_pump_speed
    from diagnostics.real.zema import CIRCUIT
    from sim.rigs import load_rig

    rig = load_rig(latest_version(session, get_rig(session, rig_id, field="--rig")).document)
    if rig.circuit.name != CIRCUIT:
        raise CircuitError(
            f"ZeMA cycles belong to a rig of the {CIRCUIT!r} circuit; rig {rig_id} "
            f"({rig.spec.name!r}) is a {rig.circuit.name!r} circuit (register the ZeMA rig: "
            "hydrodiag rigs add sim/rigs/zema.yaml, and give its id)", field="--rig")
    return stated_pump_speed(rig.values(), field="--rig")


def _write_bench(records: list[SeriesRecord], speed: float, relaxation: float, path: Path,
                 provenance: str) -> int:
    """Write the records' settled working plateaus as a pump-bench CSV; return the rows."""
    from diagnostics.pump import write_bench_csv
    from diagnostics.real.profile import settled_bench

    data = settled_bench(records, speed, relaxation=relaxation, provenance=provenance)
    try:
        write_bench_csv(data, path)
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror}", field="--bench") from None
    return int(data.q.size)
