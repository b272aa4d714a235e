"""Command line of the service: ``hydrodiag serve | keys ... | db ... | jobs ...`` and the
work commands ``simulate | diagnose | sweep | calibrate`` (:mod:`app.cli_runs`, ``diagnose`` in
:mod:`app.cli_diagnose`).

``serve`` migrates the store, preloads the paper-002 reference rig and its throttle tables
(missing clearances computed by :class:`~app.services.throttle_estimator.
ThrottleClearanceEstimator`), creates an API key on the first start (printed on a terminal, written to
``<data dir>/first-api-key`` where the output is a log), then runs the HTTP server.
"""

from __future__ import annotations

import io
import logging
import os
import socket
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import Progress
from rich.table import Table
from sqlalchemy import Engine

from app.cli_batch import register as register_batch
from app.cli_command import use_command_class
from app.cli_db import db_cli
from app.cli_discover import register as register_discover
from app.cli_history import history_cli
from app.cli_jobs import jobs_cli
from app.cli_pump_leak import register as register_pump_leak
from app.cli_report import report_cli
from app.cli_rigs import rigs_cli
from app.cli_runs import register
from app.cli_support import (
    as_option,
    console,
    migrated_engine,
    settings_from_env,
    steps,
    store_id,
    unwrap_help,
)
from app.db.engine import make_engine, make_session_factory
from app.security import Scope
from app.settings import Settings
from sim.errors import HydrodiagError, InputError

__all__ = ["cli", "main"]

cli = typer.Typer(
    name="hydrodiag", help="Fault diagnosis of hydraulic rigs: service and store.",
    no_args_is_help=True, add_completion=False,
)
keys_cli = typer.Typer(help="API keys (only salted hashes are stored).", no_args_is_help=True)
cli.add_typer(keys_cli, name="keys")
cli.add_typer(db_cli, name="db")
cli.add_typer(rigs_cli, name="rigs")
cli.add_typer(jobs_cli, name="jobs")
cli.add_typer(history_cli, name="history")

#: where ``serve`` leaves the first API key when its output is not a terminal (a log)
FIRST_KEY_FILE = "first-api-key"


def first_key_shown(line: str) -> str | None:
    """The first API key that a line of ``serve``'s output shows: printed on a terminal, or
    read from the file it names where the output is piped; ``None`` for any other line
    (the benchmarks and tests that start ``serve`` read its key so)."""
    if not line.startswith("API key: "):
        return None
    shown = line.split(": ", 1)[1].strip()
    if shown.startswith("written to "):
        path = shown.removeprefix("written to ").split(" (", 1)[0]
        return Path(path).read_text(encoding="utf-8").strip()
    return shown.split(" ", 1)[0] if shown.startswith("hd_") else None


def _show_first_key(key: str, data_dir: Path) -> None:
    """Show the first API key once: on a terminal, printed; otherwise (a service log under
    systemd or docker, which keeps what it is given) written to :data:`FIRST_KEY_FILE` in
    the data folder, readable by this user only, and only its path printed — an operator
    pass found the admin key in the journal, where the logs promise "never keys"."""
    console.print("[bold]First start: an API key was created; send it in the X-API-Key "
                  "header.[/bold]")
    if sys.stdout.isatty():
        typer.echo(f"API key: {key} (shown only now)")
        return
    path = (data_dir / FIRST_KEY_FILE).resolve()
    try:
        descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.fchmod(descriptor, 0o600)             # a file left by an earlier store keeps none
        with os.fdopen(descriptor, "w", encoding="utf-8") as file:
            file.write(key + "\n")
    except OSError as exc:
        typer.echo(f"API key: not shown in a log, and not written to {path} ({exc.strerror}):"
                   " make one from this shell with `hydrodiag keys create --name admin "
                   "--scope admin`")
        return
    typer.echo(f"API key: written to {path} (readable by this user only), not to this "
               "log; read it, keep it, delete the file")


def _settings(**overrides: object) -> Settings:
    return settings_from_env(**overrides)


def _engine(settings: Settings) -> Engine:
    return make_engine(settings.url)


def _migrated_engine() -> Engine:
    return migrated_engine()


def _steps() -> Progress:
    return steps()


def _check_port(host: str, port: int, *, host_field: str = "HYDRODIAG_HOST") -> None:
    """Refuse a port another process listens on, before the store is migrated and the
    first key made: a busy port was found after both, the key printed by a start that
    failed and never again, and with several workers the error named no port (an
    operator's pass).  Bound as uvicorn binds (``SO_REUSEADDR``), then released."""
    try:
        family, kind, proto, _, address = socket.getaddrinfo(
            host, port, type=socket.SOCK_STREAM)[0]
        with socket.socket(family, kind, proto) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind(address)
    except socket.gaierror as exc:   # a host that names no interface, not a busy port
        raise InputError(f"cannot listen on {host}: no such interface ({exc.strerror or exc})",
                         field=host_field) from None
    except OSError as exc:
        raise InputError(f"cannot listen on {host}:{port} ({exc.strerror or exc}): is another "
                         "service there? give another port (--port, HYDRODIAG_PORT) or "
                         "interface (--host, HYDRODIAG_HOST)", field="HYDRODIAG_PORT") from None


@cli.command()
def serve(
    host: Annotated[str | None, typer.Option(help="Interface to bind [HYDRODIAG_HOST].")] = None,
    port: Annotated[int | None, typer.Option(help="TCP port [HYDRODIAG_PORT].")] = None,
) -> None:
    """Migrate, preload the reference rig, make the first key, then serve HTTP."""
    from sqlalchemy.exc import DatabaseError

    from app.cgroup_limits import memory_warning, usable_cores
    from app.logs import configure_logging
    from app.services.bootstrap import (
        bootstrap_lock,
        ensure_first_key,
        ensure_reference_data,
        store_problem,
        upgrade_database,
        warn_open_file,
    )
    from app.services.heap import limit_arenas
    from app.services.throttle_estimator import ThrottleClearanceEstimator
    from app.settings import settings_line, unknown_variables
    from app.supervisor import exec_supervisor, supervisor_argv

    settings = _settings(host=host, port=port)
    limit_arenas()  # for every process started from here (app.services.heap)
    configure_logging(settings.log_format, settings.log_level)
    log = logging.getLogger("hydrodiag.app")
    for name in unknown_variables():
        log.warning("environment variable %s is no setting of hydrodiag: ignored", name)
    log.info(settings_line(settings))
    short = memory_warning(settings.workers, settings.diagnosis_processes,
                           0 if settings.dask_scheduler else
                           settings.sweep_workers or usable_cores())
    if short is not None:
        log.warning(short)
    _check_port(settings.host, settings.port,   # before anything is written
                host_field="HYDRODIAG_HOST" if host is None else "--host")
    estimator = ThrottleClearanceEstimator()
    engine = _engine(settings)
    sessions = make_session_factory(engine)
    try:
        with _steps() as progress, bootstrap_lock(engine):  # one replica at a time
            task = progress.add_task("migrating the store", total=3)
            revision = upgrade_database(engine)
            warn_open_file(engine)
            progress.update(task, advance=1, description="preloading the reference rig")
            with sessions() as session:
                preloaded = ensure_reference_data(session, estimator=estimator)
            progress.update(task, advance=1, description="checking API keys")
            with sessions() as session:
                first_key = ensure_first_key(session)
            progress.update(task, advance=1, description="store ready")
    except (OSError, DatabaseError) as exc:   # one line naming the store, not a traceback
        problem = store_problem(engine, exc)
        if problem is None:
            raise
        raise problem from None
    finally:
        engine.dispose()
    console.print(f"store at revision {revision}: {settings.url.render_as_string()}")
    if preloaded.rig_created or preloaded.calibrations_created:
        console.print(f"preloaded the reference rig and {preloaded.calibrations_created} "
                      "throttle tables")
    if first_key is not None:
        _show_first_key(first_key, settings.data_dir)
    # the server builds the app from the environment: this process becomes uvicorn's alone
    # (app.supervisor), without what it imported and loaded to ready the store
    exec_supervisor(supervisor_argv(
        host=settings.host, port=settings.port, workers=settings.workers,
        log_level=settings.log_level, log_format=settings.log_format,
        keep_alive_s=settings.keep_alive_s,
        forwarded_allow_ips=settings.forwarded_allow_ips))


@keys_cli.command("create")
def keys_create(
    name: Annotated[str, typer.Option(help="Unique name of the key (who or what uses it).")],
    scope: Annotated[str, typer.Option(
        metavar="read|write|admin",
        help="What the key may do: read (reads, /simulate, unstored /diagnose), write "
             "(also store and change), admin (also delete).")],
) -> None:
    """Create an API key and print it (only now: the store keeps its hash)."""
    from app.services.keys import create_api_key

    # parsed here, not by typer: its enum check came out as "Value error, 'x' is not one
    # of …" (pydantic's prefix) in the usage error
    choices = ", ".join(repr(s.value) for s in Scope)
    try:
        chosen = Scope(scope.strip().lower())
    except ValueError:
        raise typer.BadParameter(f"{scope!r} is not one of {choices}.",
                                 param_hint="'--scope'") from None

    engine = _migrated_engine()
    with make_session_factory(engine)() as session:
        _, plaintext = create_api_key(session, name, chosen)
    engine.dispose()
    typer.echo(plaintext)


@keys_cli.command("list")
def keys_list() -> None:
    """List the keys (names, prefixes and scopes; the keys themselves are not stored)."""
    from app.services.keys import list_api_keys

    engine = _migrated_engine()   # a listing makes no store (EXISTING_STORE_COMMANDS)
    table = Table("id", "name", "prefix", "scope", "created", "revoked")
    with make_session_factory(engine)() as session:
        for row in list_api_keys(session):
            table.add_row(str(row.id), escape(row.name), row.prefix, row.scope,
                          f"{row.created_at:%Y-%m-%d %H:%M}",
                          f"{row.revoked_at:%Y-%m-%d %H:%M:%S}" if row.revoked_at else "")
    engine.dispose()
    Console(width=160).print(table)


@keys_cli.command("revoke")
def keys_revoke(key_id: Annotated[int, typer.Argument(parser=store_id,
                                                     help="Id shown by `keys list`.")]) -> None:
    """Revoke a key: it stops working at once (a rotated key's grace period ends)."""
    from app.services.keys import revoke_api_key

    engine = _migrated_engine()
    with make_session_factory(engine)() as session:
        row = revoke_api_key(session, key_id)
    engine.dispose()
    when = f" at {row.revoked_at:%Y-%m-%d %H:%M:%S} UTC" if row.revoked_at else ""
    console.print(f"key {row.id} ({row.name}) revoked{when}", markup=False)  # an earlier
    # revocation (or a rotation's grace end) keeps its own time: revoking again changes nothing


@keys_cli.command("rotate")
def keys_rotate(
    key_id: Annotated[int, typer.Argument(parser=store_id, help="Id shown by `keys list`.")],
    grace: Annotated[float, typer.Option(
        help="Seconds the old key keeps working, 0 (default: revoked at once) to 604800 "
             "(7 days).")] = 0.0,
) -> None:
    """Replace a key by a new one with the same name and scope; print the new key.

    The old key is renamed `<name>.rotated-<id>` and stops working after the grace period.
    """
    from app.services.keys import rotate_api_key

    engine = _migrated_engine()
    with make_session_factory(engine)() as session:
        try:
            old, new, plaintext = rotate_api_key(session, key_id, grace_s=grace)
        except InputError as exc:   # named "grace", the API's field (a review's leftover)
            raise as_option(exc, {"grace": "--grace"}) from None
        old_id, new_id, ends = old.id, new.id, old.revoked_at
    engine.dispose()
    when = "now" if not grace else f"at {ends:%Y-%m-%d %H:%M:%S} UTC"
    typer.echo(f"key {old_id} replaced by key {new_id}; the old key stops working {when}",
               err=True)
    typer.echo(plaintext)


register(cli)
cli.add_typer(report_cli, name="report")
register_discover(cli)
register_pump_leak(cli)
register_batch(cli)
unwrap_help(cli)
use_command_class(cli)


def _database_trouble(reason: str) -> str:
    """What an operational error means: a server that answered and refused (a database or
    role that does not exist, a wrong password) is not one that "did not answer" (an
    operator pass: that pointed at the network for a misspelt database name)."""
    refused = ("does not exist", "password authentication failed", "no pg_hba.conf entry",
               "role ", "permission denied")
    if any(word in reason.lower() for word in refused):
        return "the database server refused the connection"
    return "the database did not answer"


def main() -> None:
    """Entry point of the ``hydrodiag`` command."""
    from sqlalchemy.exc import DatabaseError, InterfaceError, OperationalError

    for stream in (sys.stdout, sys.stderr):
        # a terminal in ISO-8859-1 or ASCII cannot show σ, µ, ≈ or …: shown as "?" there
        # rather than a UnicodeEncodeError traceback from every command (a CLI pass)
        if "utf" not in (getattr(stream, "encoding", None) or "utf").lower() \
                and isinstance(stream, io.TextIOWrapper):
            stream.reconfigure(errors="replace")
    try:
        cli()
    except HydrodiagError as exc:
        console.print(f"[red]{type(exc).__name__}:[/red] {escape(str(exc))}")
        for more in (exc.details or [])[1:]:  # a batch's other refused records, each
            console.print(f"  {escape(str(more['field']))}: {escape(str(more['message']))}")
        sys.exit(1)
    except (OperationalError, InterfaceError) as exc:
        # an unreachable database or a wrong password: one line, not 500 of traceback
        reason = str(exc.orig).strip().splitlines()[0] if exc.orig is not None else str(exc)
        console.print(f"[red]{_database_trouble(reason)} ({type(exc).__name__}):[/red] "
                      f"{escape(reason)} (HYDRODIAG_DATABASE_URL)")
        sys.exit(1)
    except DatabaseError as exc:
        # a role that may not create tables (PostgreSQL 15's "public"), a file that is not
        # a database: 341-line tracebacks from db upgrade (an operator pass)
        reason = str(exc.orig).strip().splitlines()[0] if exc.orig is not None else str(exc)
        advice = (": make the role the database's owner, or GRANT CREATE ON SCHEMA public to "
                  "it" if "permission denied" in reason.lower() else "")
        console.print(f"[red]the database refused ({type(exc).__name__}):[/red] "
                      f"{escape(reason)}{advice} (HYDRODIAG_DATABASE_URL)")
        sys.exit(1)


if __name__ == "__main__":
    main()
