"""Helpers shared by the command-line modules: console, settings, store, progress."""

from __future__ import annotations

import inspect
import json
import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from pydantic import ValidationError
from rich.console import Console, ConsoleDimensions
from rich.markup import escape
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table
from sqlalchemy import Engine
from sqlalchemy.orm import Session

from app.db.engine import make_engine, make_session_factory, sqlite_path
from app.schemas.common import MAX_ID
from app.settings import Settings
from sim.errors import HydrodiagError, InputError

if TYPE_CHECKING:
    from diagnostics.timeseries import ColumnEntry

__all__ = ["EXISTING_STORE_COMMANDS", "PIPE_WIDTH", "ColumnMapOption", "SampleRateOption",
           "SinceOption", "UntilOption", "WideWhenPiped", "as_option", "console",
           "estimate_text", "load_document", "migrated_engine", "name_values", "print_json",
           "reading_options",
           "running_command", "series_ids", "settings_from_env", "shown_estimate",
           "shown_scale", "steps", "store_id", "store_session", "store_setting",
           "unwrap_help", "validated", "validation_error", "writable"]

#: columns of a table or message written to a pipe or a file [characters]
PIPE_WIDTH = 240


class WideWhenPiped(Console):
    """A console that lays out in the terminal's width, and in :data:`PIPE_WIDTH` columns
    when its output is not a terminal: rich's 80-column default cut a piped ``jobs list``'s
    status to "runn…" and wrapped each row over three lines (an operator pass)."""

    @property
    def size(self) -> ConsoleDimensions:
        """Columns and lines of the layout [characters]."""
        own = super().size
        return own if self.is_terminal else ConsoleDimensions(PIPE_WIDTH, own.height)

    @size.setter
    def size(self, new_size: tuple[int, int]) -> None:
        Console.size.fset(self, new_size)  # type: ignore[attr-defined]

    def print(self, *objects: Any, **kwargs: Any) -> None:
        """Print as rich does, a table's cells folded onto more lines where the terminal is
        narrow rather than cut with "…": at 40 columns ``cylinder+valve`` and
        ``cylinder+pump`` both read ``cylinder+…`` and intervals lost their digits (a CLI
        pass)."""
        for item in objects:
            if isinstance(item, Table):
                for column in item.columns:
                    if column.overflow == "ellipsis":
                        column.overflow = "fold"
        super().print(*objects, **kwargs)


console = WideWhenPiped(stderr=True)


def settings_from_env(**overrides: object) -> Settings:
    """The service settings from the environment, with non-``None`` overrides applied."""
    try:
        settings = Settings()
        changes = {k: v for k, v in overrides.items() if v is not None}
        return Settings.model_validate(settings.model_dump() | changes) if changes else settings
    except ValidationError as exc:
        from app.errors import plain_message

        # each problem by its option when one gave it (serve --port 0 was said to be
        # HYDRODIAG_PORT's: a CLI pass), else by its variable; never the value: a database
        # URL holds a password
        def named(loc: tuple[int | str, ...]) -> str:
            key = "_".join(str(p) for p in loc)
            variable = f"HYDRODIAG_{key.upper() or 'SETTINGS'}"
            given = overrides.get(key) is not None
            return f"--{key.replace('_', '-')}" if given else variable

        lines = [f"{named(e['loc'])}: {plain_message(e['msg'])}"
                 for e in exc.errors(include_input=False, include_url=False)]
        console.print("[red]invalid configuration (options or HYDRODIAG_* variables):[/red]\n"
                      + escape("\n".join(lines)))
        raise typer.Exit(code=2) from None


#: the commands (their paths) that read the store or change only what it holds already:
#: where there is none they say so and make none (:func:`migrated_engine`); ``jobs list``
#: run from the wrong folder made an empty store and exited 0, and a ``db backup`` there
#: then "succeeded" on it (an operator's pass); ``calibrate tables`` and ``report`` still
#: made one (a review's leftover).  Every other command makes the store it opens,
#: preloaded as ``serve`` makes it, and says so (the README's ``simulate`` and ``diagnose``
#: run on the reference rig of a new store).
EXISTING_STORE_COMMANDS = frozenset({
    "calibrate tables", "history list", "history show", "jobs cancel", "jobs list",
    "jobs show", "keys list", "keys revoke", "keys rotate", "report diagnosis",
    "report trends", "rigs list", "rigs rediagnose", "rigs series", "rigs show"})
#: the path of the command running (``"history list"``), set by the commands' class
#: (:class:`app.cli_command.HydrodiagCommand`); empty outside a command
running_command: ContextVar[str] = ContextVar("running_command", default="")


def store_setting(settings: Settings) -> str:
    """The variable that chose the store: ``HYDRODIAG_DATABASE_URL`` when set, else
    ``HYDRODIAG_DATA_DIR`` (the embedded file in its folder), for messages about it."""
    return "HYDRODIAG_DATA_DIR" if settings.database_url is None else "HYDRODIAG_DATABASE_URL"


def migrated_engine(*, existing: bool | None = None) -> Engine:
    """Engine of the configured store, migrated to the newest revision first.  With
    ``existing`` — by default, for the :data:`EXISTING_STORE_COMMANDS` — a missing SQLite
    store (a PostgreSQL database that holds no table) is refused, naming it and the
    variables that point at one, and none is made; otherwise a missing store is made and a
    line on stderr says so.

    Raises
    ------
    InputError
        No store at the configured path (``field``: the variable that set it).
    """
    from sqlalchemy.exc import DatabaseError

    from app.services.bootstrap import (
        bootstrap_lock,
        store_problem,
        upgrade_database,
        warn_open_file,
    )

    settings = settings_from_env()
    url = settings.url
    if existing is None:
        existing = running_command.get() in EXISTING_STORE_COMMANDS
    if existing:
        from app.db.copy import existing_store

        existing_store(url, field=store_setting(settings))
    file = sqlite_path(url)
    fresh = file is not None and not file.exists()
    engine = make_engine(url)
    try:
        if not existing and file is None and url.get_backend_name() != "sqlite":
            from app.db.copy import holds_no_table

            # a database that holds no table is made a store as a missing file is (a key
            # made in an empty PostgreSQL database by a mistyped URL went unremarked);
            # with ``existing`` existing_store has just refused such a database
            fresh = holds_no_table(engine)
        with bootstrap_lock(engine):
            upgrade_database(engine)
            warn_open_file(engine)
    except (OSError, DatabaseError) as exc:  # one line naming the store, as serve says it
        problem = store_problem(engine, exc)
        if problem is None:
            raise
        raise problem from None
    if fresh:
        # a command run from another folder used that folder's ./data: a key made there
        # worked on no running service (an operator pass)
        where = ("HYDRODIAG_DATABASE_URL" if settings.database_url is not None else
                 "HYDRODIAG_DATA_DIR, default ./data of the current folder")
        made = file if file is not None else url.render_as_string()  # password hidden
        console.print(f"[yellow]a new, empty store was made at {escape(str(made))}"
                      f"[/yellow] ({where}; the service's store is where it was started, or "
                      "its HYDRODIAG_DATA_DIR / HYDRODIAG_DATABASE_URL)")
    return engine


@contextmanager
def store_session(*, existing: bool | None = None) -> Iterator[Session]:
    """A session of the configured store, migrated and with the reference rig and tables
    preloaded as ``serve`` does; the engine is disposed after.  ``existing``: a missing
    store is refused, not made (default: for the :data:`EXISTING_STORE_COMMANDS`,
    :func:`migrated_engine`)."""
    from app.services.bootstrap import bootstrap_lock, ensure_reference_data
    from app.services.throttle_estimator import ThrottleClearanceEstimator

    engine = migrated_engine(existing=existing)
    try:
        with make_session_factory(engine)() as session:
            with bootstrap_lock(engine):
                ensure_reference_data(session, estimator=ThrottleClearanceEstimator())
            yield session
    finally:
        engine.dispose()


def steps() -> Progress:
    """A rich progress display with a bar and the elapsed time."""
    return Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(),
                    TimeElapsedColumn(), console=console)


def load_document(path: str) -> Any:
    """Read a JSON or YAML file (by its suffix; YAML otherwise)."""
    import json

    import yaml

    from sim.yaml_loader import load_yaml

    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot read {p}: {exc.strerror}", field="FILE") from None
    except UnicodeDecodeError:
        raise InputError(f"{p.name} is not UTF-8 text (JSON or YAML)", field="FILE") from None
    try:
        return json.loads(text) if p.suffix.lower() == ".json" else load_yaml(text)
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        raise InputError(f"{p.name} is not valid JSON or YAML: {exc}", field="FILE") from None


def writable(path: Path, option: str) -> Path:
    """``path`` if a file can be written there (its folder exists, it is not a folder), else
    an :class:`InputError` on ``option``: checked before the work whose result it takes, so
    a wrong path costs neither the work nor a half-done store (``discover`` stored its new
    rig version, then failed writing the report)."""
    if path.is_dir():
        raise InputError(f"{path} is a folder; give a file name", field=option)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(f"cannot write {path}: no folder {folder}", field=option)
    if not os.access(folder, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise InputError(f"cannot write {path}: permission denied", field=option)
    return path


def counted(n: int, noun: str) -> str:
    """``counted(1, "record")`` → ``"1 record"``, ``counted(3, "record")`` → ``"3 records"``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def estimate_text(value: float, low: float, high: float) -> tuple[str, str]:
    """An estimate and its interval as text with as many significant digits (4 to 10) as it
    takes to tell the interval's ends apart: at a fixed 3 digits a tight interval read
    "6e-05 … 6e-05" beside a value of 5.999e-05 that seemed to lie outside it."""
    digits = 4
    while digits < 10 and f"{low:.{digits}g}" == f"{high:.{digits}g}":
        digits += 1
    return f"{value:.{digits}g}", f"{low:.{digits}g} … {high:.{digits}g}"


def shown_estimate(value: float, low: float, high: float, unit: str
                   ) -> tuple[str, str, str]:
    """:func:`estimate_text` in the unit an engineer reads, and that unit: a length below a
    centimetre (a clearance) in µm, as :func:`sim.units.quantity_text` says it in a
    sentence ("6.007e-05 (5.844e-05 … 6.174e-05) m" is "60.07 (58.44 … 61.74) µm")."""
    factor, unit = shown_scale(unit, value, low, high)
    shown, interval = estimate_text(factor * value, factor * low, factor * high)
    return shown, interval, unit


def shown_scale(unit: str, *values: float) -> tuple[float, str]:
    """(factor, unit) in which ``values`` of SI ``unit`` are shown together: lengths below
    a centimetre (clearances) in µm, else as they are (:func:`shown_estimate`)."""
    if unit == "m" and 0.0 < max(abs(v) for v in values) < 1e-2:
        return 1e6, "µm"
    return 1.0, unit


#: ``--since``: the start of a window of stored records (as the HTTP ``since``)
SinceOption = Annotated[str | None, typer.Option(
    help="Only records taken at or after this time: '2026-05-01 08:00' (UTC), ISO 8601 "
    "with zone, or a date (the start of that day, UTC).")]
#: ``--until``: its end (as the HTTP ``until``)
UntilOption = Annotated[str | None, typer.Option(
    help="Only records taken at or before this time: '2026-05-01 18:00' (UTC), ISO 8601 "
    "with zone, or a date (the end of that day, UTC).")]


def series_ids(text: str, *, field: str = "--series") -> list[int]:
    """``"3, 4,5"`` → ``[3, 4, 5]``; anything else is an :class:`InputError` on ``field``."""
    try:
        ids = [int(x) for x in text.split(",")]
    except ValueError:
        raise InputError(f"not a comma-separated list of ids: {text!r}", field=field
                         ) from None
    if any(not 1 <= i <= MAX_ID for i in ids):
        raise InputError(f"series ids are 1 to {MAX_ID}", field=field)
    return ids


def store_id(text: str) -> int:
    """A stored thing's id on the command line (``--rig 3``, ``RIG_ID``): a whole number
    from 1 to :data:`~app.schemas.common.MAX_ID`, as the API takes it.  A parser, not
    ``min``/``max``: the range ``[1<=x<=2147483647]`` that those print in every help
    widened the types column until an 80-column help cut option names
    (``--displacement-cm3-r…``; a CLI pass)."""
    try:
        value = int(text)
    except ValueError:
        raise typer.BadParameter(f"{text!r} is not an id (a whole number from 1)") from None
    if not 1 <= value <= MAX_ID:
        raise typer.BadParameter(f"{value} is not an id: ids run from 1 to {MAX_ID}")
    return value


#: ``--column-map`` of the commands that read a logger's file (``import series``, ``diagnose``)
ColumnMapOption = Annotated[str | None, typer.Option(
    help='A logger\'s own layout: JSON raw column → \\[channel, unit], e.g. '
         '\'{"PS1": \\["P_pump", "bar"], "run": \\["record", "-"]}\'; a raw signal → '
         '\\[channel, unit, gain, offset] (gain·raw + offset in unit), a column to leave '
         'out → \\["skip", "-"].')]
#: ``--sample-rate`` of the same commands
SampleRateOption = Annotated[float | None, typer.Option(
    help="Samples per second of a file without a time column \\[Hz].")]


def reading_options(column_map: str | None, sample_rate: float | None,
                    started_at: str | None
                    ) -> tuple[dict[str, ColumnEntry] | None, float | None, datetime | None]:
    """``--column-map``, ``--sample-rate`` and ``--started-at`` as the time-series reader
    takes them: the map parsed, the rate checked, the start read with its zone.

    Raises
    ------
    InputError
        Naming the option: a map that is not one, a rate ≤ 0, a start without its zone.
    """
    from app.services.series import parse_column_map
    from diagnostics.timeseries import MAX_SAMPLE_RATE, clock_time

    if sample_rate is not None and not 0 < sample_rate <= MAX_SAMPLE_RATE:
        raise InputError(f"the sample rate must be above 0 and at most {MAX_SAMPLE_RATE:g} "
                         "Hz", field="--sample-rate")
    cmap = parse_column_map(column_map, field="--column-map")
    start = None if started_at is None else clock_time(started_at, field="--started-at")
    return cmap, sample_rate, start


def validation_error(exc: ValidationError) -> InputError:
    """The first problem of a pydantic validation error as an :class:`InputError`."""
    from app.errors import first_problem

    return first_problem(exc.errors())


def unwrap_help(app: typer.Typer) -> None:
    """Give every command of ``app`` (and of its sub-apps) its docstring as help with each
    paragraph on one line: typer 0.29 prints the single line breaks of a docstring's later
    paragraphs as they are, which at 80 columns left every other line a word or two long.
    Paragraphs stay apart; rich wraps each to the terminal.  Literals written for the
    API documentation (````VACUUM INTO````) are shown as 'VACUUM INTO' (the backquotes were
    printed as they are: a CLI pass)."""
    for info in app.registered_commands:
        if info.help is None and info.callback is not None and info.callback.__doc__:
            doc = re.sub(r"``([^`]+)``", r"'\1'", inspect.cleandoc(info.callback.__doc__))
            info.help = "\n\n".join(" ".join(p.split()) for p in doc.split("\n\n"))
    for group in app.registered_groups:
        if group.typer_instance is not None:
            unwrap_help(group.typer_instance)


def validated(model: Any, document: Any, options: dict[str, str] | None = None) -> Any:
    """``document`` validated as ``model``; an error names the option the user typed where
    ``options`` maps the model's field to it (``displacement_m3_rad`` → ``--displacement``)."""
    try:
        return model.model_validate(document)
    except ValidationError as exc:
        raise as_option(validation_error(exc), options) from None


def as_option(exc: HydrodiagError, options: dict[str, str] | None) -> HydrodiagError:
    """``exc`` with its field renamed to the command's option when ``options`` maps it, or
    maps the list the field is an item of (``parameters[0]`` → ``--parameter``), or maps
    to ``"--set *"`` the mapping the field is a key of (``overrides.valve.cv`` → ``--set
    valve.cv``; it was named as the API names it: a CLI pass)."""
    field = exc.field or ""
    for name, option in (options or {}).items():
        if field == name or field.startswith(f"{name}["):
            return type(exc)(exc.message, field=option)
        if field.startswith(f"{name}.") and option.endswith(" *"):
            # a mapping's key given as an option's value (overrides.valve.cv → --set valve.cv)
            return type(exc)(exc.message, field=f"{option[:-2]} {field[len(name) + 1:]}")
    return exc


def print_json(payload: Any) -> None:
    """``payload`` as indented JSON on stdout (the API's answer, ``--json``)."""
    typer.echo(json.dumps(payload, indent=2, default=str))


def name_values(items: list[str], *, field: str = "--set", form: str = "role.name=value"
                ) -> dict[str, float]:
    """``name=value`` options as numbers by name; :class:`InputError` naming ``field``
    where one is not of that ``form``."""
    out: dict[str, float] = {}
    for item in items:
        name, _, value = item.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise InputError(f"expected {form}, got {item!r}", field=field) from None
    return out
