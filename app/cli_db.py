"""``hydrodiag db``: the store's schema (upgrade, downgrade, current), its backup and its copy
into another database."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from sqlalchemy import Engine

from app.cli_support import console, settings_from_env, steps, store_setting
from app.db.engine import make_engine, private_file, sqlite_path
from sim.errors import InputError

__all__ = ["db_cli"]

db_cli = typer.Typer(help="The store's schema and its backup.", no_args_is_help=True)


def _revision(revision: str) -> str:
    """``revision`` if this release ships it (or ``head``/``base``), else an InputError."""
    from app.db import migrate

    if revision in ("head", "base") or revision in migrate.known_revisions():
        return revision
    raise InputError(f"unknown revision {revision!r}: this release ships "
                     f"{', '.join(sorted(migrate.known_revisions()))}", field="--revision")


@db_cli.command("upgrade")
def db_upgrade(
    revision: Annotated[str, typer.Option(help="Target revision.")] = "head",
) -> None:
    """Migrate the store forward (default: to the newest revision)."""
    from app.db import migrate
    from app.services.bootstrap import require_known_revision

    engine = make_engine(settings_from_env().url)
    try:
        target = _revision(revision)
        current = require_known_revision(engine)
        if target != "head" and current is not None and current > target:
            # Alembic's upgrade to an older revision does nothing, silently (an operator pass)
            raise InputError(f"the store is at revision {current}, past {target}: upgrade only "
                             "moves forward (db downgrade --revision goes back, dropping what "
                             "the later revisions added)", field="--revision")
        with steps() as progress:
            task = progress.add_task(f"migrating to {target}", total=1)
            migrate.upgrade(engine, target)
            progress.update(task, advance=1)
        console.print(f"store at revision {migrate.current_revision(engine)}")
    finally:
        engine.dispose()


@db_cli.command("downgrade")
def db_downgrade(
    revision: Annotated[str, typer.Option(help="Target revision (an older one).")],
    yes: Annotated[bool, typer.Option("--yes", help="Drop what the later revisions added.")
                   ] = False,
) -> None:
    """Migrate the store back to an older revision (to run an older release on it): the
    tables and columns that later revisions added are dropped with what they hold.  Back
    the store up first (db backup)."""
    from app.db import migrate
    from app.services.bootstrap import require_known_revision

    engine = make_engine(settings_from_env().url)
    try:
        target = _revision(revision)
        current = require_known_revision(engine)
        if current is None or (target != "base" and target >= current):
            raise InputError(f"the store is at revision {current}, not past {target}: nothing "
                             "to take back", field="--revision")
        lost = _downgrade_losses(engine, current, target)
        if not yes:
            backup = ("pg_dump" if engine.url.get_backend_name() == "postgresql"
                      else "db backup FILE")
            raise InputError(f"going back from {current} to {target} drops what the later "
                             "revisions added and what it holds" + "".join(
                                 f"; {line}" for line in lost)
                             + f": back the store up ({backup}) and say --yes", field="--yes")
        migrate.downgrade(engine, target)
        console.print(f"store at revision {migrate.current_revision(engine)}")
        for line in lost:
            console.print(line, markup=False)
    finally:
        engine.dispose()


def _downgrade_losses(engine: Engine, current: str, target: str) -> list[str]:
    """What a downgrade from ``current`` to ``target`` takes that the older release's
    history then lacks, in counts (an upgrade pass: re-diagnosed visits read twice in the
    older release and after it, joint visits lost their records, under a generic "drops
    what later revisions added")."""
    from sqlalchemy import func, select

    from app.db.base import utcnow
    from app.db.models import (
        ApiKey,
        ConsoleLogout,
        Diagnosis,
        DiagnosisRecord,
        IdempotentRequest,
        MeasuredSeries,
    )

    lines: list[str] = []
    below = target == "base"

    def crosses(revision: str) -> bool:
        return current >= revision and (below or target < revision)

    with engine.connect() as connection:
        # whole tables a crossed revision drops (a verification pass: the measured series
        # went unnamed), and the keys' scopes
        for revision, model, what in (("0003", MeasuredSeries, "measured series"),
                                      ("0010", IdempotentRequest, "kept Idempotency-Key "
                                                                  "answers")):
            if not crosses(revision):
                continue
            rows = connection.scalar(select(func.count()).select_from(model)) or 0
            if rows:
                lines.append(f"{rows} {what} are deleted (revision {revision} added them)")
        if crosses("0004"):
            scoped = connection.scalar(select(func.count()).where(
                ApiKey.scope != "admin", ApiKey.revoked_at.is_(None))) or 0
            if scoped:
                lines.append(f"{scoped} read or write API keys can do everything below 0004 "
                             "(scopes came with it): revoke them first where that matters")
        if crosses("0012"):
            lines.append("the estimates' stored intervals are dropped (migrating up again "
                         "fills them from the diagnoses' results)")
        if crosses("0014"):
            replaced = connection.scalar(
                select(func.count()).where(Diagnosis.superseded_by.is_not(None))) or 0
            if replaced:
                lines.append(f"{replaced} {_plural(replaced, 'diagnosis', 'diagnoses')} "
                             "replaced by a re-diagnosis read as current "
                             "in the older release (its history and trends show those visits "
                             "twice); migrating up again marks them anew")
        if crosses("0015"):
            ended = connection.scalar(select(func.count()).select_from(ConsoleLogout).where(
                ConsoleLogout.expires_at >= utcnow())) or 0
            if ended:
                lines.append(f"{ended} console "
                             f"{_plural(ended, 'session logged out works', 'sessions logged out work')}"
                             " again below 0015 until they expire (12 h "
                             "after login): revoke the key where a copied cookie matters")
        if crosses("0008"):
            joint = connection.scalar(select(func.count()).select_from(
                select(DiagnosisRecord.diagnosis_id).group_by(DiagnosisRecord.diagnosis_id)
                .having(func.count() > 1).subquery())) or 0
            if joint:
                lines.append(f"{joint} joint {_plural(joint, 'diagnosis keeps', 'diagnoses keep')}"
                             " only the record the result is kept with: the links to the "
                             "visit's other records are lost for good (deleting one of those "
                             "records no longer deletes the diagnosis)")
    return lines


def _plural(n: int, one: str, more: str) -> str:
    return one if n == 1 else more


@db_cli.command("revisions")
def db_revisions() -> None:
    """List the store revisions this release ships, oldest first, each with its date and
    what it added, and mark the store's.  An older release needs the newest revision it
    ships itself: the highest ``rNNNN`` in its ``app/migrations/versions/`` (the dates have
    no time of day, and two revisions of one day straddled a release: a verification
    pass); take the store there with db downgrade --revision NNNN."""
    from app.db import migrate
    from app.db.copy import existing_store

    settings = settings_from_env()
    url = settings.url
    existing_store(url, field=store_setting(settings))
    engine = make_engine(url)
    try:
        current = migrate.current_revision(engine)
    finally:
        engine.dispose()
    for revision, date, summary in migrate.revision_list():
        mark = "  ← the store" if revision == current else ""
        typer.echo(f"{revision}  {date}  {summary}{mark}")


@db_cli.command("current")
def db_current() -> None:
    """Print the store's schema revision (empty for an unmigrated store)."""
    from app.db import migrate
    from app.db.copy import existing_store

    settings = settings_from_env()
    url = settings.url
    existing_store(url, field=store_setting(settings))
    engine = make_engine(url)
    try:
        typer.echo(migrate.current_revision(engine) or "")
    finally:
        engine.dispose()


@db_cli.command("backup")
def db_backup(
    file: Annotated[Path, typer.Argument(help="The copy to write (must not exist).")],
) -> None:
    """Copy an SQLite store to FILE, consistent, while the service runs and writes.

    SQLite's ``VACUUM INTO`` copies one snapshot in one read transaction: 0.7 s for a
    115 MB store under 45 writes/s, where the sqlite3 shell's ``.backup`` restarts at each
    write and did not finish until the writes stopped (18 s; an operator pass).  A
    PostgreSQL store is backed up with ``pg_dump``.
    """
    from sqlalchemy import text

    from app.db.copy import existing_store

    settings = settings_from_env()
    url = settings.url
    if (store := sqlite_path(url)) is None:
        raise InputError("db backup copies an SQLite file; back a PostgreSQL store up with "
                         "pg_dump", field="HYDRODIAG_DATABASE_URL")
    existing_store(url, field=store_setting(settings))  # not a new, empty store backed up
    if file.exists():
        raise InputError(f"{file} exists: a backup is written to a new file", field="FILE")
    if not file.parent.is_dir():
        raise InputError(f"no folder {file.parent}", field="FILE")
    engine = make_engine(url)
    # the backup as private as the store (it was world-readable: an operator's pass)
    private_file(file, store.stat().st_mode & 0o666)
    try:
        with engine.connect() as connection:
            connection.exec_driver_sql("VACUUM INTO ?", (str(file),))
        copied = make_engine(url.set(database=str(file)))
        try:
            with copied.connect() as copy:
                ok = copy.execute(text("PRAGMA integrity_check")).scalar()
        finally:
            copied.dispose()
        if ok != "ok":   # pragma: no cover - a copy SQLite just wrote
            raise InputError(f"the copy {file} failed its integrity check: {ok}", field="FILE")
    finally:
        engine.dispose()
    console.print(f"store copied to {file} ({file.stat().st_size / 1e6:.1f} MB, integrity ok)")


@db_cli.command("copy")
def db_copy(
    target: Annotated[str, typer.Argument(
        help="The empty store to copy into, as a URL: postgresql+psycopg://user:password@host/db "
             "or sqlite:///path/file.db.")],
) -> None:
    """Copy the whole store (HYDRODIAG_DATABASE_URL, by default the embedded SQLite file)
    into an empty one, e.g. to move to PostgreSQL: one consistent snapshot, every id kept,
    the target migrated first and its id sequences set after; the service may keep running
    (what it writes after the snapshot is not copied).  Then point HYDRODIAG_DATABASE_URL
    at the target."""
    from rich.table import Table
    from sqlalchemy.engine import make_url

    from app.db.copy import copy_store
    from app.settings import Settings

    try:
        # the checks a service applies to its own URL (a weak password was copied into, and
        # serve then refused it); the URL is not echoed: it holds a password (an operator pass)
        Settings._check_url(target)
    except ValueError as exc:
        raise InputError(f"{exc} (give postgresql+psycopg://user:password@host/db or "
                         "sqlite:///path/file.db)", field="TARGET") from None
    target_url = make_url(target)
    if target_url.get_backend_name() == "postgresql" and target_url.get_driver_name() != "psycopg":
        raise InputError("write the scheme as postgresql+psycopg:// (the psycopg driver is the "
                         "one installed)", field="TARGET")
    if (target_file := sqlite_path(target_url)) is not None:
        # sqlite:///tmp/x.db is the relative tmp/x.db: its folders were made under the
        # current one and the message named the URL, not the file (an operator pass)
        folder = target_file.resolve().parent
        if not folder.is_dir():
            raise InputError(f"no folder {folder} (sqlite:///relative/path, "
                             "sqlite:////absolute/path)", field="TARGET")
    import signal

    def stop(signum: int, _frame: object) -> None:
        # as Ctrl-C: the snapshot of the store in the temporary folder is removed (a
        # dropped SSH session left a 192 MB copy of every diagnosis and key hash in /tmp)
        raise KeyboardInterrupt(f"signal {signum}")

    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, stop)
    settings = settings_from_env()
    source_url = settings.url
    with steps() as progress:
        task = progress.add_task("copying", total=None)

        def advance(table: str, rows: int) -> None:
            progress.update(task, description=f"copying {table}: {rows} rows")

        copied = copy_store(source_url, target_url, advance,
                            source_field=store_setting(settings))
    out = Table("table", "rows", title=f"revision {copied.revision}, counts checked")
    for name, rows in copied.rows.items():
        out.add_row(name, str(rows))
    console.print(out)
    where = (str(target_file.resolve()) if target_file is not None
             else target_url.render_as_string(hide_password=True))
    console.print(f"{sum(copied.rows.values())} rows copied to {where}")
    ends = ", ".join(f"{name} {copied.last_ids[name]}" for name in
                     ("rigs", "rig_versions", "diagnoses", "measurements", "measured_series")
                     if copied.last_ids.get(name))
    if ends:
        console.print(f"the copy ends at the largest ids {ends}: what the store took after "
                      "them is not in the copy")
