"""``hydrodiag diagnose-batch FILE --rig ID``: thousands of records, each diagnosed alone.

FILE is a CSV (one record per row; ``condition.oil_temperature`` style column names nest,
as the console's CSV upload) or JSON Lines (one record, as in ``POST /diagnose``, per
line).  Every record is validated as the API validates it: records the API would refuse
are all reported with their line and field (up to :data:`LISTED`), and the batch is refused
before anything runs, or with ``--skip-invalid`` the others are diagnosed and each refused
record gets its error line in ``--out`` (one bad logger row threw a night's batch away: a
fleet integrator's pass).  A file that is not a readable table stays refused whole.  Then
all go through
:func:`diagnostics.batch.diagnose_many` — in this process, on a local process pool
(``--workers N``) or on a Dask cluster (``--dask tcp://host:8786``, the executor sweeps
use) — with a progress bar.  The results are not stored in the history (use
``POST /diagnose`` for that); ``--out`` writes one JSON line per record.
"""

from __future__ import annotations

import json
import time
from collections import Counter
from collections.abc import Sequence
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
from sim.errors import HydrodiagError, InputError, MeasurementError

__all__ = ["LISTED", "diagnose_batch", "read_batch", "register"]


#: How many refused records an error message lists.
LISTED = 10


def read_batch(path: Path, rig_id: int
               ) -> tuple[list[tuple[int, Any]], list[tuple[int, InputError]], str]:
    """The records of ``path`` (CSV or JSON Lines) as validated ``MeasurementIn``, each
    with its 1-based number, the error of each record the API would refuse (``field``
    names the line or row and the field), and what a record is called (``row`` of a CSV,
    ``line`` of JSON Lines); a record without ``rig_id`` gets ``rig_id``.

    Raises
    ------
    InputError
        Unreadable file, not a table (CSV) or a line not JSON (JSON Lines), no records.
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
    records, errors = [], []
    for n, row in enumerate(rows, start=1):
        if not isinstance(row, dict):
            errors.append((n, InputError(f"{where} {n} is not a record (a mapping)",
                                         field=f"{where} {n}")))
            continue
        row.setdefault("rig_id", rig_id)
        try:
            records.append((n, MeasurementIn.model_validate(row)))
        except ValidationError as exc:
            err = validation_error(exc)
            inner = f": {err.field}" if err.field else ""
            errors.append((n, InputError(err.message, field=f"{where} {n}{inner}")))
    return records, errors, where


def _refused(errors: Sequence[tuple[int, HydrodiagError]], total: int) -> InputError:
    """One error listing the refused records (the first :data:`LISTED`)."""
    listed = "; ".join(f"{e.field}: {e.message}" for _, e in errors[:LISTED])
    more = f"; and {len(errors) - LISTED} more" if len(errors) > LISTED else ""
    return InputError(f"{counted(len(errors), 'record')} of {total} would be refused by the "
                      f"API: {listed}{more} (--skip-invalid diagnoses the others)",
                      field=errors[0][1].field)


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
    skip_invalid: Annotated[bool, typer.Option(
        "--skip-invalid", help="Diagnose the valid records when some would be refused; each "
        "refused record gets its error line in --out.")] = False,
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
    numbered, errors, where = read_batch(file, rig_id)
    total = len(numbered) + len(errors)
    if errors and (not skip_invalid or not numbered):
        raise _refused(errors, total)
    numbers = [n for n, _ in numbered]
    items = [item for _, item in numbered]
    rig_ids = {item.rig_id for item in items}
    if len(rig_ids) > 1:
        raise InputError(f"one rig per batch; the file names rigs {sorted(rig_ids)}",
                         field="rig_id")
    with store_session() as session:
        resolved = RigCache(1).get(session, rig_ids.pop(), None)
    now = datetime.now(UTC)
    records, kept = [], []
    for n, item in zip(numbers, items, strict=True):
        try:   # the checks on the rig's physics (a pressure below vacuum, ...)
            records.append(to_record(item, path=f"{where} {n}", rig_name=resolved.name,
                                     measured_at=item.measured_at or now))
            kept.append((n, item))
        except MeasurementError as exc:
            inner = str(exc.field or "").removeprefix(f"{where} {n}").lstrip(".")
            errors.append((n, MeasurementError(
                exc.message, field=f"{where} {n}" + (f": {inner}" if inner else ""))))
    errors.sort(key=lambda ne: ne[0])
    if errors and (not skip_invalid or not records):
        raise _refused(errors, total)
    numbers, items = [n for n, _ in kept], [item for _, item in kept]
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
            lines = [(n, {"record": n, "rig_id": item.rig_id,
                          "measured_at": None if item.measured_at is None
                          else item.measured_at.isoformat()} | r)
                     for n, item, r in zip(numbers, items, results, strict=True)]
            lines += [(n, {"record": n, "error": {
                "type": type(e).__name__, "field": e.field, "message": e.message}})
                for n, e in errors]
            for _, line in sorted(lines, key=lambda nl: nl[0]):
                fh.write(json.dumps(line, default=str) + "\n")
    counts = Counter(r.get("top", "error") for r in results)
    table = Table("top", "records", title=f"{counted(len(results), 'record')} in {elapsed:.1f} s "
                  f"({len(results) / elapsed:.0f} records/s)")
    for name, n in counts.most_common():
        table.add_row(escape(name), str(n))
    if errors:
        table.add_row("refused (invalid record)", str(len(errors)))
    console.print(table)
    for _, e in errors[:LISTED]:
        console.print(f"refused {e.field}: {e.message}", markup=False)
    if len(errors) > LISTED:
        console.print(f"… and {len(errors) - LISTED} more refused records"
                      + (f" (all in {out})" if out is not None else ""), markup=False)
    console.print("not stored in the history" + (f"; results in {out}" if out is not None
                                                 else " (--out FILE keeps the results)"),
                  markup=False)


def register(cli: typer.Typer) -> None:
    """Add ``diagnose-batch`` to the ``hydrodiag`` command."""
    cli.command("diagnose-batch")(diagnose_batch)
