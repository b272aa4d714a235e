"""``hydrodiag diagnose-batch FILE --rig ID``: thousands of records, each diagnosed alone.

FILE is a CSV (one record per row; ``condition.oil_temperature`` style column names nest,
as the console's CSV upload) or JSON Lines (one record, as in ``POST /diagnose``, per
line).  Every record is validated as the API validates it (a bad one is reported with its
line and field, and the batch is refused before anything runs), then all go through
:func:`diagnostics.batch.diagnose_many` — in this process, on a local process pool
(``--workers N``) or on a Dask cluster (``--dask tcp://host:8786``, the executor sweeps
use) — with a progress bar.  The results are not stored in the history (use
``POST /diagnose`` for that); ``--out`` writes one JSON line per record.
"""

from __future__ import annotations

import json
import time
from collections import Counter
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, Any

import typer
from pydantic import ValidationError
from rich.markup import escape
from rich.table import Table

from app.cli_support import console, counted, steps, store_session, writable
from app.schemas.common import MAX_ID
from app.schemas.record_csv import record_rows
from sim.errors import InputError

__all__ = ["diagnose_batch", "read_batch", "register"]


def read_batch(path: Path, rig_id: int) -> list[Any]:
    """The records of ``path`` (CSV or JSON Lines) as validated ``MeasurementIn``; a
    record without ``rig_id`` gets ``rig_id``.

    Raises
    ------
    InputError
        Unreadable file, no records, or a record the API would refuse (``field`` names
        the line or row and the field).
    """
    from app.cli_support import validation_error
    from app.schemas.diagnose import MeasurementIn

    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read {path}: {exc}", field="FILE") from None
    if path.suffix.lower() in (".jsonl", ".ndjson", ".json"):
        rows = []
        for n, line in enumerate(text.splitlines(), start=1):
            if not line.strip():
                continue
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError as exc:
                raise InputError(f"line {n} is not JSON: {exc.msg}", field=f"line {n}") from None
        where = "line"
    else:
        rows = record_rows(text.encode(), field="FILE")
        where = "row"
    if not rows:
        raise InputError("the file holds no records", field="FILE")
    records = []
    for n, row in enumerate(rows, start=1):
        if not isinstance(row, dict):
            raise InputError(f"{where} {n} is not a record (a mapping)", field=f"{where} {n}")
        row.setdefault("rig_id", rig_id)
        try:
            records.append(MeasurementIn.model_validate(row))
        except ValidationError as exc:
            err = validation_error(exc)
            inner = f": {err.field}" if err.field else ""
            raise InputError(err.message, field=f"{where} {n}{inner}") from None
    return records


def diagnose_batch(
    file: Annotated[Path, typer.Argument(help="Records: CSV (a row each) or JSON Lines.")],
    rig_id: Annotated[int, typer.Option("--rig", min=1, max=MAX_ID, help="Rig id in the store "
                                        "(for records that name none).")] = 1,
    workers: Annotated[int, typer.Option(min=0, max=256, help="Local worker processes; 0 runs "
                                         "in this process.")] = 0,
    dask: Annotated[str | None, typer.Option(help="Dask scheduler address (tcp://host:8786)."
                                             )] = None,
    out: Annotated[Path | None, typer.Option(help="Write one JSON result per line here.")
                   ] = None,
    full: Annotated[bool, typer.Option(help="Whole diagnoses instead of summaries.")] = False,
) -> None:
    """Diagnose every record of FILE on its own against its stored rig, with progress.

    Nothing is stored: the results go to --out and the summary table (POST /diagnose keeps
    diagnoses in the history).
    """
    from app.services.executors import SweepExecutors
    from app.services.measurements import to_record
    from app.services.rig_cache import RigCache
    from diagnostics.batch import diagnose_many

    if out is not None:
        writable(out, "--out")
    items = read_batch(file, rig_id)
    rig_ids = {item.rig_id for item in items}
    if len(rig_ids) > 1:
        raise InputError(f"one rig per batch; the file names rigs {sorted(rig_ids)}",
                         field="rig_id")
    with store_session() as session:
        resolved = RigCache(1).get(session, rig_ids.pop(), None)
    now = datetime.now(UTC)
    records = [to_record(item, path=f"record {n}", rig_name=resolved.name,
                         measured_at=item.measured_at or now)
               for n, item in enumerate(items, start=1)]
    executors = SweepExecutors(workers=workers or 1, dask_scheduler=dask) \
        if workers or dask else None
    executor = None
    if executors is not None:
        try:
            executor = executors.get()
        except (OSError, ValueError, TimeoutError) as exc:  # a bad or unreachable address
            raise InputError(f"cannot use the Dask scheduler {dask!r}: {exc}",
                             field="--dask") from None
    started = time.perf_counter()
    try:
        with steps() as progress:
            task = progress.add_task(f"diagnosing {counted(len(records), 'record')}",
                                     total=len(records))

            def tick(done: int, total: int) -> None:
                progress.update(task, completed=done)

            results = diagnose_many(resolved.rig, records, progress=tick, full=full,
                                    executor=executor)
    finally:
        if executors is not None:
            executors.shutdown()
    elapsed = time.perf_counter() - started
    if out is not None:
        with out.open("w", encoding="utf-8") as fh:
            # each line says which record it answers (the input's 1-based record number, as
            # the errors count them, its rig and stated time): lines joined to their inputs
            # by order alone (a fleet integrator's pass)
            for n, (item, r) in enumerate(zip(items, results, strict=True), start=1):
                line = {"record": n, "rig_id": item.rig_id,
                        "measured_at": None if item.measured_at is None
                        else item.measured_at.isoformat()} | r
                fh.write(json.dumps(line, default=str) + "\n")
    counts = Counter(r.get("top", "error") for r in results)
    table = Table("top", "records", title=f"{counted(len(results), 'record')} in {elapsed:.1f} s "
                  f"({len(results) / elapsed:.0f} records/s)")
    for name, n in counts.most_common():
        table.add_row(escape(name), str(n))
    console.print(table)
    console.print("not stored in the history" + (f"; results in {out}" if out is not None
                                                 else " (--out FILE keeps the results)"),
                  markup=False)


def register(cli: typer.Typer) -> None:
    """Add ``diagnose-batch`` to the ``hydrodiag`` command."""
    cli.command("diagnose-batch")(diagnose_batch)
