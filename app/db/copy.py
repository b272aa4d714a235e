"""Copy a whole store into an empty one: SQLite → PostgreSQL (or any way round).

The source is read in one consistent snapshot: an SQLite store through a ``VACUUM INTO``
copy made first (what ``hydrodiag db backup`` makes), a PostgreSQL one in a
``REPEATABLE READ`` transaction, so the service may keep running and writing while it
copies; what it writes after the snapshot is not in the copy (stop it, or take its writes
away from the old store, for the cut-over).  The target is migrated to the newest revision
and must hold no rows; every table of the store's schema is copied through the models'
own column types (timestamps stay aware UTC, JSON documents stay documents on JSONB), in
foreign-key order and by primary key, with every id kept, in one transaction: a copy that
fails leaves the target's tables empty (a target that holds rows is refused before anything
is written to it, migration included).  The target's id counters are then set past the
largest id the source ever gave out (SQLite's ``sqlite_sequence``, PostgreSQL's
sequences), deleted rows' included, so an id is never given twice, and the row counts of
both sides are compared.  A source SQLite file that does not exist (a PostgreSQL database
that holds no table), or a store that holds no row, is refused (never created).  API keys
are copied with their hashes: the clients' keys keep working.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from sqlalchemy import Connection, Engine, Table, func, inspect, select, text
from sqlalchemy.engine import URL
from sqlalchemy.exc import DatabaseError, InterfaceError, OperationalError, SQLAlchemyError

from app.db import migrate
from app.db.base import Base
from app.db.engine import make_engine, sqlite_path
from sim.errors import InputError

__all__ = ["BATCH", "Copied", "copy_store", "existing_store", "holds_no_table"]

#: rows read and written at a time
BATCH = 500

Progress = Callable[[str, int], None]


@dataclass(frozen=True)
class Copied:
    """What :func:`copy_store` copied: rows per table (equal on both sides) and the
    schema revision both are at."""

    rows: dict[str, int]
    revision: str
    #: the largest id of each table in the snapshot: where the copy ends (writes after it
    #: are not in it; an operator pass could not see the cut-over gap)
    last_ids: dict[str, int] = field(default_factory=dict)


def _tables() -> list[Table]:
    # the model metadata's tables, parents before children
    import app.db.models  # noqa: F401 - registers the tables

    return list(Base.metadata.sorted_tables)


def _counts(connection: Connection, tables: list[Table]) -> dict[str, int]:
    return {t.name: int(connection.execute(select(func.count()).select_from(t)).scalar_one())
            for t in tables}


def _check_source(engine: Engine, tables: list[Table], setting: str) -> str:
    head = migrate.head_revision()
    current = migrate.current_revision(engine)
    if current != head:
        # it named HYDRODIAG_DATABASE_URL for the default file nobody set (an upgrade
        # pass): the store by its place, the field the setting it was found through
        where = engine.url.render_as_string(hide_password=True)
        raise InputError(f"the store {where} is at revision {current or 'none'}, not {head}: "
                         "migrate it first (hydrodiag db upgrade with the same "
                         "HYDRODIAG_DATA_DIR / HYDRODIAG_DATABASE_URL), then copy",
                         field=setting)
    have = set(inspect(engine).get_table_names()) - {"alembic_version"}
    unknown = sorted(have - {t.name for t in tables})
    if unknown:
        raise InputError(f"the store has tables this release does not know ({', '.join(unknown)})"
                         ": copy it with the release that made them",
                         field="HYDRODIAG_DATABASE_URL")
    return head


def _prepare_target(engine: Engine, tables: list[Table]) -> None:
    """Migrate the target to the newest revision; refuse one that holds any row."""
    names = set(inspect(engine).get_table_names())
    current = migrate.current_revision(engine) if "alembic_version" in names else None
    if names and current is None:
        raise InputError("the target holds tables but no hydrodiag schema: copy into an empty "
                         "database", field="TARGET")
    if current is not None and current > migrate.head_revision():
        raise InputError(f"the target is at revision {current}, newer than this release's "
                         f"{migrate.head_revision()}", field="TARGET")
    # counted before anything is written: a refused target (another installation behind a
    # mistyped URL) was migrated first and then refused (an operator pass)
    with engine.connect() as connection:
        full = {k: n for k, n in _counts(connection, [t for t in tables if t.name in names]
                                         ).items() if n}
    if full:
        held = ", ".join(f"{n} {k}" for k, n in full.items())
        raise InputError(f"the target holds data ({held}): copy into an empty store (a "
                         "service started on it preloads the reference rig); nothing was "
                         "written to it", field="TARGET")
    migrate.upgrade(engine, "head")


def _reason(exc: SQLAlchemyError) -> str:
    orig = getattr(exc, "orig", None)
    return (str(orig) if orig is not None else str(exc)).strip().splitlines()[0]


def _where(url: URL) -> str:
    path = sqlite_path(url)
    return str(path.resolve()) if path is not None else url.render_as_string(hide_password=True)


def _same(a: URL, b: URL) -> bool:
    return a.render_as_string(hide_password=False) == b.render_as_string(hide_password=False)


class _RowRefusedError(SQLAlchemyError):
    """A batch the target refused, with its table and its rows' first and last id."""

    def __init__(self, where: str, cause: SQLAlchemyError) -> None:
        super().__init__(str(cause))
        self.where, self.orig = where, getattr(cause, "orig", cause)


def _table_of(exc: SQLAlchemyError) -> str:
    return exc.where if isinstance(exc, _RowRefusedError) else "a table"


def _copy_tables(source: Connection, target: Connection, tables: list[Table],
                 progress: Progress | None) -> None:
    for table in tables:
        order = list(table.primary_key.columns) or list(table.columns)
        rows = source.execution_options(yield_per=BATCH).execute(
            select(table).order_by(*order))
        done = 0
        for part in rows.partitions(BATCH):
            batch = [dict(r._mapping) for r in part]
            try:  # the whole copy's transaction is rolled back on the way out
                target.execute(table.insert(), batch)
            except SQLAlchemyError as exc:
                # which table and rows (a U+0000 in a rig document read "unsupported
                # Unicode escape sequence" and nothing else; an operator pass)
                key = order[0].name
                raise _RowRefusedError(f"{table.name} ({key} {batch[0].get(key)}…"
                                  f"{batch[-1].get(key)})", exc) from exc
            done += len(part)
            if progress is not None:
                progress(table.name, done)


def _high_water(source: Connection, tables: list[Table]) -> dict[str, int]:
    """The largest id each table has given out, deleted rows' included: SQLite's
    ``sqlite_sequence`` (the tables keep AUTOINCREMENT, revision 0007), PostgreSQL's
    sequences.  Setting the target past only the copied rows' largest id handed a deleted
    series' id out again, and a stored record that named it pointed at an unrelated cycle
    (an operator pass)."""
    if source.dialect.name == "sqlite":
        if not source.execute(text("SELECT 1 FROM sqlite_master WHERE type = 'table' AND "
                                   "name = 'sqlite_sequence'")).first():
            return {}
        rows = source.execute(text("SELECT name, seq FROM sqlite_sequence")).all()
        return {str(name): int(seq) for name, seq in rows}
    out: dict[str, int] = {}
    if source.dialect.name == "postgresql":
        for table, col in _serials(tables):
            seq = source.execute(text("SELECT pg_get_serial_sequence(:t, :c)"),
                                 {"t": table.name, "c": col}).scalar()
            if seq is not None:
                last, called = source.execute(
                    text(f"SELECT last_value, is_called FROM {seq}")).one()
                out[table.name] = int(last) if called else int(last) - 1
    return out


def _serials(tables: list[Table]) -> list[tuple[Table, str]]:
    """The tables with one integer primary key, and its column."""
    out = []
    for table in tables:
        pk = list(table.primary_key.columns)
        if len(pk) == 1 and pk[0].type.python_type is int:
            out.append((table, pk[0].name))
    return out


def _set_high_water(target: Connection, tables: list[Table], high: dict[str, int],
                    last: dict[str, int]) -> None:
    """The target's id counters past the source's high-water marks ``high`` and the copied
    rows' largest ids ``last`` (by table)."""
    if target.dialect.name == "sqlite":
        for table, _ in _serials(tables):
            top = max(high.get(table.name, 0), last.get(table.name, 0))
            if top <= 0:
                continue
            target.execute(text("DELETE FROM sqlite_sequence WHERE name = :t"),
                           {"t": table.name})
            target.execute(text("INSERT INTO sqlite_sequence (name, seq) VALUES (:t, :s)"),
                           {"t": table.name, "s": top})
        return
    if target.dialect.name != "postgresql":
        return
    for table, col in _serials(tables):
        seq = target.execute(text("SELECT pg_get_serial_sequence(:t, :c)"),
                             {"t": table.name, "c": col}).scalar()
        if seq is None:
            continue
        top = max(high.get(table.name, 0), last.get(table.name, 0))
        # setval(s, n, true): the next id is n + 1; an untouched table starts at 1
        target.execute(text("SELECT setval(:s, :n, :called)"),
                       {"s": seq, "n": max(top, 1), "called": top > 0})


def holds_no_table(engine: Engine) -> bool:
    """Whether the database of ``engine`` holds no table (but Alembic's, left by a
    downgrade to the base): a PostgreSQL database just created, where a store would be
    made as in a missing SQLite file."""
    with engine.connect() as connection:
        return not set(inspect(connection).get_table_names()) - {"alembic_version"}


def existing_store(url: URL, field: str = "HYDRODIAG_DATABASE_URL") -> None:
    """Refuse a store that does not exist, naming it: an SQLite file that is missing, or a
    database of another backend that holds no table; opening it would make a new, empty
    store (a copy or backup run from the wrong folder made one and then "copied 0 rows",
    exit 0; an operator pass; ``jobs list`` on a URL naming an empty PostgreSQL database
    made the whole schema there and listed nothing).  A server that cannot be reached is
    left to the caller to report, as it does without this check."""
    if url.get_backend_name() != "sqlite":
        engine = make_engine(url)
        try:
            empty = holds_no_table(engine)
        except (OperationalError, InterfaceError):
            return
        finally:
            engine.dispose()
        if empty:
            raise InputError(f"no store at {url.render_as_string()}: the database holds no "
                             "table; set HYDRODIAG_DATABASE_URL to the service's database (or "
                             "HYDRODIAG_DATA_DIR to its data folder)", field=field)
        return
    if (file := sqlite_path(url)) is None:
        raise InputError("an in-memory store cannot be copied or backed up", field=field)
    path = file.resolve()
    if not path.is_file():
        raise InputError(f"no store at {path}: set HYDRODIAG_DATA_DIR to the service's data "
                         "folder (default ./data of the current folder) or "
                         "HYDRODIAG_DATABASE_URL", field=field)


def copy_store(source_url: URL, target_url: URL, progress: Progress | None = None, *,
               source_field: str = "HYDRODIAG_DATABASE_URL") -> Copied:
    """Copy every row of the store at ``source_url`` into the empty store at
    ``target_url`` (module docstring).

    Parameters
    ----------
    source_url, target_url
        SQLAlchemy URLs (SQLite file or PostgreSQL).
    progress
        Called with (table, rows copied so far) as batches are written.
    source_field
        The setting that chose the source, named by the refusals about it (the CLI's
        :func:`app.cli_support.store_setting`: ``HYDRODIAG_DATA_DIR`` for the folder's
        file).

    Raises
    ------
    InputError
        The two are the same store; the source is missing, empty or not at this
        release's revision (``field`` ``source_field``); the target holds data,
        cannot be reached or made, or refuses a row (``TARGET``).  Nothing is written to a
        target that holds data, and a refused copy leaves its tables empty.
    """
    if _same(source_url, target_url):
        raise InputError("the target is the store itself", field="TARGET")
    existing_store(source_url, field=source_field)
    tables = _tables()
    engine = make_engine(source_url)
    try:
        revision = _check_source(engine, tables, source_field)
        with engine.connect() as connection:
            if not any(_counts(connection, tables).values()):
                raise InputError(f"the store at {_where(source_url)} holds no rows: nothing to "
                                 "copy (is HYDRODIAG_DATA_DIR the service's data folder?)",
                                 field="HYDRODIAG_DATABASE_URL")
    finally:
        engine.dispose()
    target = make_engine(target_url)
    try:
        try:
            _prepare_target(target, tables)
        except (OperationalError, InterfaceError) as exc:
            raise InputError(f"the target did not answer: {_reason(exc)}", field="TARGET"
                             ) from exc
        except DatabaseError as exc:
            # a role without CREATE on "public" (PostgreSQL 15), a file that is not a
            # database: 363- and 495-line tracebacks (an operator pass)
            reason = _reason(exc)
            advice = (": make the role the database's owner, or GRANT CREATE ON SCHEMA public "
                      "to it" if "permission denied" in reason.lower() else "")
            raise InputError(f"the target refused: {reason}{advice}", field="TARGET") from exc
        except OSError as exc:
            raise InputError(f"the target cannot be made: {exc.strerror or exc} "
                             f"({exc.filename or _where(target_url)})", field="TARGET") from exc
        with tempfile.TemporaryDirectory(prefix="hydrodiag-copy-") as folder:
            snapshot_url = source_url
            if source_url.get_backend_name() == "sqlite":
                snapshot = Path(folder) / "snapshot.db"
                engine = make_engine(source_url)
                try:
                    with engine.connect() as connection:
                        connection.exec_driver_sql("VACUUM INTO ?", (str(snapshot),))
                finally:
                    engine.dispose()
                snapshot_url = source_url.set(database=str(snapshot))
            engine = make_engine(snapshot_url)
            try:
                options = ({"isolation_level": "REPEATABLE READ"}
                           if engine.dialect.name == "postgresql" else {})
                with engine.connect().execution_options(**options) as src, src.begin():
                    expected = _counts(src, tables)
                    last = {t.name: int(src.execute(text(
                        f'SELECT COALESCE(MAX("{col}"), 0) FROM "{t.name}"')).scalar_one())
                        for t, col in _serials(tables)}
                    try:
                        high = _high_water(src, tables)
                        with target.begin() as dst:
                            _copy_tables(src, dst, tables, progress)
                            _set_high_water(dst, tables, high, last)
                            got = _counts(dst, tables)
                            if got != expected:  # pragma: no cover - rows lost in flight
                                raise InputError(f"the copy's row counts {got} differ from "
                                                 f"the store's {expected}; nothing was kept",
                                                 field="TARGET")
                    except SQLAlchemyError as exc:
                        raise InputError(f"the target refused a row of {_table_of(exc)}, and "
                                         f"its tables were left empty: {_reason(exc)}",
                                         field="TARGET") from exc
            finally:
                engine.dispose()
    finally:
        target.dispose()
    return Copied(expected, revision, last)
