"""``hydrodiag diagnose-batch FILE --rig ID``: thousands of records, each diagnosed alone.

FILE is a CSV (one record per row; ``condition.oil_temperature`` style column names nest,
as the console's CSV upload) or JSON Lines (one record, as in ``POST /diagnose``, per
line), each against its own rig (``rig_id``; ``--rig`` for records that name none).
Every record is validated as the API validates a record before its diagnosis: records it
would refuse are all reported with their line and field (up to :data:`LISTED`), and the
batch is refused before anything runs, or with ``--skip-invalid`` the others are diagnosed
and each refused record gets its error line in ``--output`` (one bad logger row threw a night's batch away: a
fleet integrator's pass); a record the diagnosis itself refuses (readings impossible on its
rig: p1 in bar cannot push the load) gets its error line in ``--output``, in the same shape.
A file that is not a readable table stays refused whole.  Then
all go through
:func:`diagnostics.batch.diagnose_many` — in this process, on a local process pool
(``--workers N``) or on a Dask cluster (``--dask tcp://host:8786``, the executor sweeps
use) — with a progress bar.  The results are not stored in the history (use
``POST /diagnose`` for that); ``--output`` writes one JSON line per record.
"""

from __future__ import annotations

import json
import time
from collections import Counter
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from pydantic import ValidationError
from rich.markup import escape
from rich.table import Table

from app.cli_support import WideWhenPiped, console, counted, steps, store_id, store_session, writable
from app.schemas.record_csv import record_rows
from app.schemas.times import iso_utc
from sim.errors import HydrodiagError, InputError, MeasurementError, NotFoundError

if TYPE_CHECKING:
    from diagnostics.measurement import MeasurementRecord

__all__ = ["LISTED", "diagnose_batch", "read_batch", "register"]


#: How many refused records an error message lists.
LISTED = 10

_out = WideWhenPiped()


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
        rows = record_rows(text.encode(), field="FILE", per_row=True)
        where = "row"
    if not rows:
        raise InputError("the file holds no records", field="FILE")
    records, errors = [], []
    for n, row in enumerate(rows, start=1):
        if isinstance(row, InputError):  # its cells (a nan): refused alone
            errors.append((n, InputError(row.message, field=f"{where} {n}")))
            continue
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


def _rate(per_second: float) -> str:
    """A rate as read: 0.22 (it read "0"), 3.4, 312 (".2g" read "3e+02")."""
    return f"{per_second:.2g}" if per_second < 10 else f"{per_second:.0f}"


def diagnose_batch(
    file: Annotated[Path, typer.Argument(
        help="Records: CSV (a row each; columns the fields of a POST /diagnose record in SI, "
        "the condition's dotted: condition.oil_temperature, condition.load_force) or JSON "
        "Lines.")],
    rig_id: Annotated[int, typer.Option("--rig", parser=store_id, help="Rig id in the store "
                                        "for records that name none (each record that names "
                                        "its rig_id is diagnosed against that rig).")] = 1,
    workers: Annotated[int, typer.Option(min=0, max=256, help="Local worker processes; 0 runs "
                                         "in this process.")] = 0,
    dask: Annotated[str | None, typer.Option(help="Dask scheduler address (tcp://host:8786)."
                                             )] = None,
    out: Annotated[Path | None, typer.Option(
        "--output", "--out", help="Write one JSON result per line here (--out: the older "
        "name, as every other command says --output).")] = None,
    full: Annotated[bool, typer.Option(help="Whole diagnoses instead of summaries.")] = False,
    skip_invalid: Annotated[bool, typer.Option(
        "--skip-invalid", help="Diagnose the valid records when some would be refused; each "
        "refused record gets its error line in --output.")] = False,
) -> None:
    """Diagnose every record of FILE on its own against its stored rig, with progress.

    Nothing is stored: the results go to --output and the summary table (POST /diagnose keeps
    diagnoses in the history).
    """
    from app.services.executors import SweepExecutors, dask_available
    from app.services.measurements import to_record
    from app.services.rig_cache import RigCache
    from diagnostics.batch import diagnose_many

    if dask and not dask_available():
        # asked for by name: running on local processes instead said nothing (a review)
        raise InputError("--dask needs dask.distributed, which is not installed here "
                         "(pip install -e '.[dask]')", field="--dask")
    if out is not None:
        writable(out, "--output")
    numbered, refused, where = read_batch(file, rig_id)
    errors: list[tuple[int, HydrodiagError]] = list(refused)
    total = len(numbered) + len(errors)
    if errors and (not skip_invalid or not numbered):
        raise _refused(errors, total)
    # each record against its own rig: a fleet's file names many (one rig per file made an
    # integrator split the fleet's export by rig: a fleet integrator's pass)
    cache = RigCache(max(1, len({item.rig_id for _, item in numbered})))
    resolved: dict[int, Any] = {}
    with store_session() as session:
        for r in sorted({item.rig_id for _, item in numbered}):
            try:
                resolved[r] = cache.get(session, r, None)
            except NotFoundError as exc:  # its records refused, the others go on
                errors += [(n, NotFoundError(exc.message, field=f"{where} {n}: rig_id"))
                           for n, item in numbered if item.rig_id == r]
    numbered = [(n, item) for n, item in numbered if item.rig_id in resolved]
    rig_ids = sorted(resolved)
    now = datetime.now(UTC)
    kept: dict[int, list[tuple[int, Any, MeasurementRecord]]] = {r: [] for r in rig_ids}
    for n, item in numbered:
        try:   # the checks on the rig's physics (a pressure below vacuum, ...)
            kept[item.rig_id].append((n, item, to_record(
                item, path=f"{where} {n}", rig_name=resolved[item.rig_id].name,
                measured_at=item.measured_at or now)))
        except MeasurementError as exc:
            inner = str(exc.field or "").removeprefix(f"{where} {n}").lstrip(".")
            errors.append((n, MeasurementError(
                exc.message, field=f"{where} {n}" + (f": {inner}" if inner else ""))))
    errors.sort(key=lambda ne: ne[0])
    n_records = sum(len(group) for group in kept.values())
    if errors and (not skip_invalid or not n_records):
        raise _refused(errors, total)
    executors = SweepExecutors(workers=workers or 1, dask_scheduler=dask, setting="--dask") \
        if workers or dask else None
    executor = None
    if executors is not None:
        try:
            executor = executors.get()
        except (OSError, ValueError, TimeoutError) as exc:  # a bad or unreachable address
            raise InputError(f"cannot use the Dask scheduler {dask!r}: {exc}",
                             field="--dask") from None
    started = time.perf_counter()
    answered: list[tuple[int, Any, dict[str, Any]]] = []
    try:
        with steps() as progress:
            task = progress.add_task(f"diagnosing {counted(n_records, 'record')}",
                                     total=n_records)
            for rig_id_, group in ((r, g) for r, g in kept.items() if g):
                before = len(answered)

                def tick(done: int, total: int, before: int = before) -> None:
                    progress.update(task, completed=before + done)

                results = diagnose_many(
                    resolved[rig_id_].rig, [r for _, _, r in group], progress=tick, full=full,
                    executor=executor,
                    workers=None if executors is None else executors.capacity(),
                    waiting=None if executors is None else executors.waiting())
                answered += [(n, item, r) for (n, item, _), r
                             in zip(group, results, strict=True)]
    finally:
        if executors is not None:
            executors.shutdown()
    elapsed = time.perf_counter() - started
    results = [r for _, _, r in answered]
    if out is not None:
        with out.open("w", encoding="utf-8") as fh:
            # each line says which record it answers (the input's 1-based record number, as
            # the errors count them, its rig and stated time): lines joined to their inputs
            # by order alone (a fleet integrator's pass)
            # (one shape for a failed record, refused before it ran or by the diagnosis,
            # its field naming the line: two shapes broke a parser, a fleet integrator's pass)
            lines = [(n, {"record": n, "rig_id": item.rig_id,
                          "measured_at": None if item.measured_at is None
                          else iso_utc(item.measured_at)} | _lined(r, f"{where} {n}"))
                     for n, item, r in answered]
            lines += [(n, {"record": n, "error": {
                "type": type(e).__name__, "field": e.field, "message": e.message}})
                for n, e in errors]
            for _, line in sorted(lines, key=lambda nl: nl[0]):
                fh.write(json.dumps(line, default=str) + "\n")
    counts = Counter(r.get("top", "error") for r in results)
    table = Table("top", "records", title=f"{counted(len(results), 'record')} in {elapsed:.1f} s "
                  f"({_rate(len(results) / elapsed)} records/s)")
    for name, n in counts.most_common():
        table.add_row(escape(name), str(n))
    if errors:
        table.add_row("refused (invalid record)", str(len(errors)))
    _out.print(table)  # the command's answer: on stdout, as other commands' tables (a CLI pass)
    for _, e in errors[:LISTED]:
        console.print(f"refused {e.field}: {e.message}", markup=False)
    if len(errors) > LISTED:
        console.print(f"… and {len(errors) - LISTED} more refused records"
                      + (f" (all in {out})" if out is not None else ""), markup=False)
    console.print("not stored in the history" + (f"; results in {out}" if out is not None
                                                 else " (--output FILE keeps the results)"),
                  markup=False)


def _lined(result: dict[str, Any], where: str) -> dict[str, Any]:
    """``result`` with the field of its error (a diagnosis that refused the record) named
    from its line or row, as a refusal before the run names it."""
    error = result.get("error")
    if not isinstance(error, dict):
        return result
    inner = error.get("field")
    return result | {"error": error | {"field": where + (f": {inner}" if inner else "")}}


def register(cli: typer.Typer) -> None:
    """Add ``diagnose-batch`` to the ``hydrodiag`` command."""
    cli.command("diagnose-batch")(diagnose_batch)
