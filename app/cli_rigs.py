"""``hydrodiag rigs``: register, list, read and version rig descriptions in the store.

The same services as ``/rigs`` over HTTP (:mod:`app.services.rigs`): a document is validated
by ``sim`` and stored in its canonical form; an update adds a version, never overwrites.
A rig file is the YAML (or JSON) that ``sim`` reads, e.g. ``sim/rigs/zema.yaml``::

    hydrodiag rigs add sim/rigs/zema.yaml        # → rig 2
    hydrodiag import zema --rig 2 --first 1 --last 200
    hydrodiag rigs rediagnose 1                  # history against the latest version
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
import yaml
from rich.markup import escape
from rich.table import Table

from app.cli_support import WideWhenPiped, load_document, steps, store_id, store_session
from sim.errors import HydrodiagError, InputError

__all__ = ["rigs_cli"]

_out = WideWhenPiped()

rigs_cli = typer.Typer(help="Rig descriptions in the store (as /rigs over HTTP).",
                       no_args_is_help=True)

FileArg = Annotated[Path, typer.Argument(help="Rig description: YAML or JSON "
                                              "(schema hydrodiag.rig/1, as sim/rigs/*.yaml).")]
CommentOption = Annotated[str | None, typer.Option(help="Note stored with the version.")]


def _document(path: Path) -> dict[str, object]:
    doc = load_document(str(path))
    if not isinstance(doc, dict):
        raise InputError(f"{path.name} is not a rig description (a mapping)", field="FILE")
    return doc


@rigs_cli.command("add")
def add(file: FileArg, comment: CommentOption = None) -> None:
    """Validate FILE and store it as version 1 of a new rig; print its id."""
    from app.services.rigs import create_rig

    doc = _document(file)
    with store_session() as session:
        rig, version = create_rig(session, doc, comment=comment)
        _out.print(f"rig {rig.id} {rig.name!r} stored (version {version.version})",
                   markup=False)


@rigs_cli.command("update")
def update(
    rig_id: Annotated[int, typer.Argument(parser=store_id, help="Rig id in the store.")],
    file: FileArg,
    comment: CommentOption = None,
) -> None:
    """Validate FILE and store it as the next version of rig RIG_ID (same name)."""
    from app.services.rigs import get_rig, latest_version, reverted_commissioned, update_rig

    doc = _document(file)
    with store_session() as session:
        rig = get_rig(session, rig_id)
        before, previous = rig.latest_version, latest_version(session, rig).document
        rig, version = update_rig(session, rig_id, doc, comment=comment)
        if version.version == before:  # the latest version's document: nothing stored
            _out.print(f"rig {rig.id} {rig.name!r}: the document is version {before}'s; "
                       "nothing stored", markup=False)
        else:
            _out.print(f"rig {rig.id} {rig.name!r}: version {version.version} stored",
                       markup=False)
            for note in reverted_commissioned(previous, version.document):
                _out.print(f"note: {note}", markup=False)


@rigs_cli.command("list")
def list_all() -> None:
    """List the stored rigs with their latest version."""
    from app.services.rigs import list_rigs

    with store_session() as session:
        rows, total = list_rigs(session, limit=10_000, offset=0)
        table = Table(title=f"{total} rigs")
        for column in ("id", "name", "version", "circuit"):
            table.add_column(column, no_wrap=True)
        table.add_column("title", overflow="fold")
        for rig, version in rows:
            table.add_row(str(rig.id), escape(rig.name), str(version.version),
                          escape(str(version.document.get("circuit", ""))), escape(rig.title))
    _out.print(table)


@rigs_cli.command("show")
def show(
    rig_id: Annotated[int, typer.Argument(parser=store_id, help="Rig id in the store.")],
    version: Annotated[int | None, typer.Option(parser=store_id,
                                                help="Version (default: latest).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="JSON instead of YAML.")] = False,
) -> None:
    """Print a stored rig description (canonical form: each value in the unit it was
    stored with, and its source); the output is a rig file ``rigs add`` and ``rigs update``
    read back."""
    from app.services.rigs import get_rig, get_version, latest_version

    with store_session() as session:
        row = (latest_version(session, get_rig(session, rig_id)) if version is None
               else get_version(session, rig_id, version))
        doc = dict(row.document)
    typer.echo(json.dumps(doc, indent=2) if as_json
               else yaml.safe_dump(doc, sort_keys=False, allow_unicode=True), nl=as_json)


@rigs_cli.command("series")
def series(
    rig_id: Annotated[int, typer.Argument(parser=store_id, help="Rig id in the store.")],
    delete: Annotated[list[int] | None, typer.Option(
        "--delete", parser=store_id, help="Delete this stored series (repeat), e.g. to "
        "import its cycles again with a corrected condition.")] = None,
) -> None:
    """List the measured series stored with a rig (GET /rigs/{id}/series): id, name,
    record, clock time, samples and stated condition; --delete ID removes series (the
    refusals of a repeated import asked for DELETE /series/{id}, which the command line
    could not do)."""
    from app.services.rigs import get_rig
    from app.services.series import delete_series, get_series, list_series

    with store_session() as session:
        if delete:
            get_rig(session, rig_id)
            for series_id in delete:   # each of this rig's, checked before any is deleted
                if get_series(session, series_id).rig_id != rig_id:
                    raise InputError(f"series {series_id} is not rig {rig_id}'s",
                                     field="--delete")
            for series_id in delete:
                delete_series(session, series_id)
            _out.print(f"deleted {len(delete)} series of rig {rig_id}: "
                       f"{', '.join(map(str, delete))}", markup=False)
            return
        rows, total = list_series(session, rig_id, limit=100_000, offset=0)
        table = Table(title=f"{total} measured series of rig {rig_id}")
        for column in ("id", "name", "record", "measured at (UTC)", "samples"):
            table.add_column(column, overflow="fold")
        table.add_column("condition", overflow="fold")
        for row in rows:
            at = "—" if row.measured_at is None else row.measured_at.isoformat(
                timespec="seconds")
            table.add_row(str(row.id), escape(row.name), escape(row.record), at,
                          str(row.n_samples), escape(", ".join(
                              f"{k}={v:g}" for k, v in (row.condition or {}).items())))
    _out.print(table)


@rigs_cli.command("rediagnose")
def rediagnose(
    rig_id: Annotated[int, typer.Argument(parser=store_id, help="Rig id in the store.")],
    version: Annotated[list[int] | None, typer.Option(
        parser=store_id, help="An older version whose diagnoses are done again (repeat); "
        "default: every version whose parameters differ from the latest's.")] = None,
) -> None:
    """Diagnose rig RIG_ID's stored records again against its latest version, as POST
    /rigs/{id}/rediagnose does: each old diagnosis is marked superseded by the new one."""
    from sqlalchemy import Engine, func, select

    from app.db.engine import make_session_factory
    from app.db.models import Diagnosis, Measurement
    from app.services.rediagnosis import plan_rediagnosis, run_rediagnosis
    from app.services.rig_cache import RigCache

    with store_session() as session:
        try:
            plan = plan_rediagnosis(session, RigCache(1), rig_id, version or None)
        except HydrodiagError as exc:  # named as this command's argument and option
            raise type(exc)(exc.message, field="--version" if exc.field and exc.field
                            .startswith("versions") else "RIG_ID") from None
        bind = session.get_bind()
        assert isinstance(bind, Engine)
        if not plan.stale:
            held = session.scalar(select(func.count()).select_from(Diagnosis).join(
                Measurement, Diagnosis.measurement_id == Measurement.id).where(
                Measurement.rig_id == rig_id))
            _out.print(f"rig {rig_id}: no stored diagnoses" if not held else
                       f"rig {rig_id}: nothing to do again — every current diagnosis was made "
                       f"with version {plan.resolved.version} or one with its parameters",
                       markup=False)
            return
        with steps() as progress:
            task = progress.add_task(f"{len(plan.stale)} diagnoses of version(s) "
                                     f"{', '.join(map(str, plan.versions))}", total=1.0)
            result = run_rediagnosis(plan, make_session_factory(bind), None,
                                     lambda done, _note: progress.update(task, completed=done))
    taken = (f", {result['skipped']} taken by another run meanwhile" if result["skipped"]
             else "") + (f"; {result['remaining']} more remain: run it again"
                         if result["remaining"] else "")
    _out.print(f"rig {rig_id}: {result['rediagnosed']} of {result['n_diagnoses']} diagnoses "
               f"done again against version {result['rig_version']}, {result['changed']} "
               f"name another fault, {len(result['errors'])} could not be done{taken}",
               markup=False)
    changed = [r for r in result["replaced"] if r["before"] != r["after"]]
    for r in changed[:20]:
        # the component blamed, as the history's `component` (its `top` names the
        # hypothesis: "relief" here is "relief_seat" there, a commissioning engineer's pass)
        _out.print(f"  diagnosis {r['diagnosis_id']} → {r['by']}: component {r['before']} → "
                   f"{r['after']}", markup=False)
    for e in result["errors"][:20]:
        _out.print(f"  diagnosis {e['diagnosis_id']} kept: {e['message']}", markup=False)
    if len(changed) > 20 or len(result["errors"]) > 20:
        _out.print("  (the first 20 of each; every one: GET /diagnoses?superseded=true)",
                   markup=False)
