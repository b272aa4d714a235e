"""``hydrodiag history``: the stored diagnoses read back from the server's shell.

The same read back as ``GET /diagnoses`` over HTTP (:mod:`app.services.readback`), on the
store the service uses (``HYDRODIAG_DATA_DIR`` / ``HYDRODIAG_DATABASE_URL``): a fleet
integrator found that the CLI could diagnose and store but not list what it stored::

    hydrodiag history list --rig 1 --since 2026-11-01
    hydrodiag history show 12 --json
"""

from __future__ import annotations

import json
from typing import Annotated, Any, cast

import typer
from rich.markup import escape
from rich.table import Table

from app.cli_support import (
    SinceOption,
    UntilOption,
    WideWhenPiped,
    shown_estimate,
    store_id,
    store_session,
)
from app.schemas.times import SinceTime, UntilTime, filter_time
from sim.errors import InputError

__all__ = ["history_cli"]

_out = WideWhenPiped()

history_cli = typer.Typer(help="Stored diagnoses read back (as /diagnoses over HTTP).",
                          no_args_is_help=True)

JsonOption = Annotated[bool, typer.Option("--json", help="Print the API's JSON answer.")]


def _estimates(item: dict[str, Any]) -> str:
    """Each stored estimate as ``cc 45.1 µm (43.2 … 47.0)``, in the unit an engineer reads."""
    parts = []
    for e in item["estimates"]:
        if e.get("value") is None or e.get("low") is None or e.get("high") is None:
            continue
        shown, interval, unit = shown_estimate(e["value"], e["low"], e["high"], e["unit"] or "")
        unit = "" if unit in ("1", "") else f" {unit}"     # a coefficient has no unit
        parts.append(f"{e['quantity']} {shown}{unit} ({interval})")
    return "; ".join(parts)


@history_cli.command("list")
def list_history(
    rig: Annotated[int | None, typer.Option(parser=store_id, help="Only this rig.")] = None,
    since: SinceOption = None,
    until: UntilOption = None,
    component: Annotated[str | None, typer.Option(
        help="Only diagnoses blaming this component (cylinder, valve, pump, relief, a pair "
        "such as valve+pump, healthy or unexplained).")] = None,
    limit: Annotated[int, typer.Option(min=1, max=500, help="At most this many, newest "
                                       "record first.")] = 50,
    as_json: JsonOption = False,
) -> None:
    """List the stored diagnoses, newest record first: time, rig, answer, probability and the
    estimates the trends keep (the full result: history show ID)."""
    from app.schemas.history import BlamedComponent
    from app.services.readback import list_diagnoses, public_diagnosis

    blamed = _component(component, BlamedComponent)
    window = filter_time(since, SinceTime, "--since"), filter_time(until, UntilTime, "--until")
    with store_session() as session:
        rows, total = list_diagnoses(session, limit=limit, offset=0, rig_id=rig,
                                     since=window[0], until=window[1], component=blamed)
        items = [public_diagnosis(r, compact=True).model_dump(mode="json", exclude={"result"})
                 for r in rows]
    if as_json:
        typer.echo(json.dumps({"items": items, "total": total}, indent=2))
        return
    table = Table(title=f"{len(items)} of {total} diagnoses")
    for name in ("id", "measured [UTC]", "rig (version)", "answer", "probability",
                 "estimates [95 %]"):
        table.add_column(name)
    for d in items:
        table.add_row(str(d["id"]), d["measured_at"][:19].replace("T", " "),
                      f"{d['rig_id']} ({d['rig_version']})", escape(d["top"] or "—"),
                      "—" if d["probability"] is None else f"{d['probability']:.2f}",
                      escape(_estimates(d)))
    _out.print(table)


def _component(text: str | None, kind: Any) -> str | None:
    """``--component`` checked against what a diagnosis can blame."""
    if text is None:
        return None
    allowed: tuple[str, ...] = kind.__args__
    if text not in allowed:
        raise InputError(f"unknown component {text!r} (one of {', '.join(allowed)})",
                         field="--component")
    return cast("str", text)


@history_cli.command("show")
def show(
    diagnosis_id: Annotated[int, typer.Argument(parser=store_id, help="Stored diagnosis "
                                                "id (history list names them).")],
    as_json: JsonOption = False,
) -> None:
    """A stored diagnosis: its records, answer, hypotheses and estimates (--json: the full
    result as GET /diagnoses/{id} answers it; report diagnosis ID: the page with charts)."""
    from app.services.readback import get_diagnosis, public_diagnosis

    with store_session() as session:
        public = public_diagnosis(get_diagnosis(session, diagnosis_id)).model_dump(mode="json")
    if as_json:
        typer.echo(json.dumps(public, indent=2))
        return
    result = public["result"]
    lines = [f"diagnosis {public['id']} of rig {public['rig_id']} (version "
             f"{public['rig_version']}), record(s) {', '.join(map(str, public['measurement_ids']))}"
             f" measured {public['measured_at'][:19].replace('T', ' ')} UTC",
             f"answer: {public['top'] or '—'}"
             + ("" if public["probability"] is None else f", p = {public['probability']:.2f}")
             + ("" if public["explained"] in (None, True) else " (not explained by the model)")]
    if public.get("superseded_by"):
        lines.append(f"superseded by diagnosis {public['superseded_by']} (a later rig version)")
    for h in result.get("hypotheses", [])[:5]:
        lines.append(f"  {h.get('name', '?'):<16} p = {h.get('probability', 0.0):.3f}")
    estimates = _estimates(public)
    if estimates:
        lines.append(f"estimates [95 %]: {estimates}")
    for line in lines:
        _out.print(line, markup=False)
