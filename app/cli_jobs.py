"""``hydrodiag jobs``: the service's jobs (sweeps, discrepancy checks) from the server's shell.

The same services as ``/jobs`` over HTTP (:mod:`app.services.jobs`), on the store the
service uses (``HYDRODIAG_DATA_DIR`` / ``HYDRODIAG_DATABASE_URL``): an operator lists what
runs, reads a job, and cancels a runaway one without an API key.  A cancel is written to
the store, which every server process reads: a queued job never starts, a running one
stops at its next progress report (``POST /jobs/{id}/cancel`` does the same)::

    hydrodiag jobs list --status running
    hydrodiag jobs cancel 3f2a...
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Annotated, Any, cast

import typer
from rich.markup import escape
from rich.table import Table

from app.cli_support import WideWhenPiped, store_session
from sim.errors import InputError

if TYPE_CHECKING:
    from app.schemas.jobs import JobStatus

__all__ = ["jobs_cli"]

_out = WideWhenPiped()

jobs_cli = typer.Typer(help="The service's jobs: list, show, cancel (as /jobs over HTTP).",
                       no_args_is_help=True)

#: the statuses a job can have (app.schemas.jobs.JobStatus)
_STATUSES = ("queued", "running", "succeeded", "failed", "cancelled")

JobArg = Annotated[str, typer.Argument(help="Job id (a UUID, as /jobs lists it).")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print the API's JSON answer.")]


def _public(job: Any) -> dict[str, Any]:
    from app.schemas.jobs import JobPublic

    return JobPublic.model_validate(job).model_dump(mode="json")


def _stamp(value: str) -> str:
    """An ISO time of the API's JSON as ``YYYY-MM-DD HH:MM:SS``."""
    return value[:19].replace("T", " ")


@jobs_cli.command("list")
def list_jobs(
    status: Annotated[str | None, typer.Option(
        help=f"Only jobs in this state: {', '.join(_STATUSES)}.")] = None,
    kind: Annotated[str | None, typer.Option(help="Only jobs of this kind, e.g. sweep.")
                    ] = None,
    limit: Annotated[int, typer.Option(min=1, max=500, help="At most this many, newest "
                                       "first.")] = 50,
    as_json: JsonOption = False,
) -> None:
    """List the jobs, newest first: kind, state, progress and the last message (results:
    jobs show ID --json)."""
    from app.schemas.jobs import job_summary
    from app.services.jobs import list_jobs as list_stored

    if status is not None and status not in _STATUSES:
        raise InputError(f"unknown status {status!r} (one of {', '.join(_STATUSES)})",
                         field="--status")
    with store_session() as session:
        jobs, total = list_stored(session, limit=limit, offset=0,
                                  status=cast("JobStatus | None", status), kind=kind,
                                  results=False)
        items = [job_summary(j).model_dump(mode="json") for j in jobs]
    if as_json:
        typer.echo(json.dumps({"items": items, "total": total}, indent=2))
        return
    table = Table(title=f"{len(items)} of {total} jobs")
    table.add_column("id", no_wrap=True)  # copied into `jobs show` / `jobs cancel` whole
    for name in ("kind", "status", "progress", "message", "created [UTC]"):
        table.add_column(name)
    for j in items:
        table.add_row(j["id"], escape(j["kind"]), j["status"], f"{100 * j['progress']:.0f} %",
                      escape(j.get("message") or ""), _stamp(j["created_at"]))
    _out.print(table)


@jobs_cli.command("show")
def show(job_id: JobArg, as_json: JsonOption = False) -> None:
    """A job's state, times, parameters and its error or the keys of its result."""
    from app.services.jobs import get_job

    with store_session() as session:
        job = get_job(session, job_id)
        public = _public(job)
    if as_json:
        typer.echo(json.dumps(public, indent=2))
        return
    lines = [f"job {public['id']} ({public['kind']}): {public['status']}, "
             f"{100 * public['progress']:.0f} %"
             + (f" — {public['message']}" if public.get("message") else "")]
    for label, key in (("created", "created_at"), ("started", "started_at"),
                       ("finished", "finished_at")):
        if public.get(key):
            lines.append(f"{label} [UTC]: {_stamp(public[key])}")
    if public.get("cancel_requested_at") and public["status"] == "running":
        lines.append(f"cancel asked [UTC]: {_stamp(public['cancel_requested_at'])} (it stops "
                     "at its next progress report)")
    lines.append(f"parameters: {json.dumps(public.get('params') or {})}")
    if public.get("error"):
        lines.append(f"error: {public['error'].get('type')}: {public['error'].get('message')}")
    if public.get("result"):
        lines.append(f"result: {', '.join(public['result'])} (--json prints it)")
    for line in lines:
        _out.print(line, markup=False)


@jobs_cli.command("cancel")
def cancel(job_id: JobArg) -> None:
    """Cancel a job: a queued one at once, a running one at its next progress report;
    a job that already succeeded or failed is refused (exit code 1)."""
    from app.services.jobs import cancel_job

    with store_session() as session:
        job = cancel_job(session, job_id)
        status, asked = job.status, job.cancel_requested_at is not None
    if status == "cancelled" and asked:
        # it ran, was asked to stop and stopped before the answer was read back
        _out.print(f"job {job_id} asked to stop: it stopped (cancelled)", markup=False)
    elif status == "cancelled":
        _out.print(f"job {job_id} cancelled", markup=False)
    else:
        _out.print(f"job {job_id} asked to stop: it stops at its next progress report "
                   "(`hydrodiag jobs show` follows it)", markup=False)
