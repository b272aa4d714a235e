"""``hydrodiag pump-leak --rig ID``: the pump's leak per stored cycle of a rig without a
cylinder (the ZeMA rig), and the steps of the leak over the cycles.

The same estimate as ``POST /rigs/{rig_id}/pump-leak`` (:mod:`app.services.pump_leak`,
:mod:`diagnostics.real.monitor`) on the store the service uses: a summary, one row per
segment between the steps (its cycles, how many leak, the median leak at the plateau
pressure in l/min, the oil's range), each cycle with ``--cycles``, the whole answer with
``--json``.  Nothing is stored.  A bad option is exit code 1 with a message naming it.
"""

from __future__ import annotations

from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from app.cli_support import (
    WideWhenPiped,
    as_option,
    console,
    print_json,
    series_ids,
    store_id,
    store_session,
    validated,
)
from app.schemas.pump_leak import MAX_CYCLES, PumpLeakRequest, PumpLeakResponse
from diagnostics.plots import shown_unit
from diagnostics.real.relaxation import ZEMA_RELAXATION
from sim.errors import HydrodiagError

__all__ = ["pump_leak_command", "register"]

_out = WideWhenPiped()

#: fields of the request → the options that fill them
_OPTIONS = {"series_ids": "--series", "baseline_series_ids": "--baseline", "last": "--last",
            "shunt": "--shunt", "relaxation": "--relaxation", "window": "--window",
            "min_segment": "--min-segment"}

#: flows as every table and chart shows them (l/min per m³/s)
_LPM, _FLOW = shown_unit("m^3/s")


def pump_leak_command(
    rig_id: Annotated[int, typer.Option("--rig", parser=store_id,
                                        help="Rig id in the store (a rig without a "
                                             "cylinder, e.g. the ZeMA rig).")],
    series: Annotated[str | None, typer.Option(
        help="Stored cycles to read: ids, comma-separated (default: the rig's stored "
             "cycles but the baseline's, the latest --last of them).")] = None,
    baseline: Annotated[str | None, typer.Option(
        help="Stored cycles known healthy to read the others against (at least 10): ids, "
             "comma-separated.")] = None,
    last: Annotated[int | None, typer.Option(
        help="Without --series: the rig's latest this many stored cycles, by clock time "
             f"(default: every one, the latest {MAX_CYCLES} when there are more).")] = None,
    shunt: Annotated[float | None, typer.Option(
        help=r"λ of the laminar shunt as given \[m³] (default: fitted on the cycles).")
    ] = None,
    relaxation: Annotated[float, typer.Option(
        help=r"Relaxation time of the accumulator gas after a pressure step \[s]; 0: "
             "plateau means.")] = ZEMA_RELAXATION,
    window: Annotated[float, typer.Option(
        help=r"Oil-temperature half-width of a cycle's healthy reference \[°C].")] = 1.0,
    min_segment: Annotated[int, typer.Option(
        help="Fewest cycles on each side of a step of the leak.")] = 10,
    cycles: Annotated[bool, typer.Option("--cycles", help="Print every cycle.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the JSON answer.")] = False,
) -> None:
    """The pump's leak per stored cycle (orifice + laminar shunt, paper 000 eq. 6 form),
    and where it steps."""
    from app.services.pump_leak import pump_leak
    from app.services.rig_cache import RigCache

    request = validated(PumpLeakRequest, {
        "series_ids": None if series is None else series_ids(series),
        "baseline_series_ids": None if baseline is None else series_ids(baseline,
                                                                          field="--baseline"),
        "last": last, "shunt": shunt, "relaxation": relaxation, "window": window,
        "min_segment": min_segment}, _OPTIONS)
    with store_session() as session:
        try:
            answer = pump_leak(session, RigCache(1), rig_id, request)
        except HydrodiagError as exc:
            raise as_option(exc, _OPTIONS | {"rig_id": "--rig"}) from None
    if as_json:
        print_json(answer.model_dump(mode="json"))
        return
    _out.print(_summary(answer), markup=False)
    _out.print(segment_table(answer))
    if cycles:
        _out.print(cycle_table(answer))
    for note in answer.notes:
        console.print(f"note: {note}", markup=False)


def _summary(a: PumpLeakResponse) -> str:
    against = ("cycles known healthy" if a.reference == "baseline"
               else "the batch's lower group")
    return (f"rig {a.rig_id} v{a.rig_version}: {len(a.cycles)} cycles, {a.leaking} leaking "
            f"(against {against}; threshold {a.threshold * _LPM:.3g} {_FLOW} of deficit), "
            f"{len(a.shifts)} step(s) of the leak; shunt λ = {a.shunt:.3g} m³, healthy "
            f"dq/dp = {a.slope * _LPM * 1e5:+.3g} {_FLOW} per bar")


def segment_table(a: PumpLeakResponse) -> Table:
    """One row per segment of cycles between the steps of the leak."""
    from app.services.pump_leak import segments

    table = Table("cycles", "first measured", "n", "leaking", rf"median leak \[{_FLOW}]",
                  r"median K \[1e-9 m³/(s·Pa^½)]", r"oil \[°C]",
                  title="segments between the steps of the leak")
    for seg in segments(a):
        when = seg.first.measured_at
        table.add_row(escape(f"{seg.first.name} … {seg.last.name}" if seg.n > 1
                             else seg.first.name),
                      "—" if when is None else when.isoformat(), str(seg.n), str(seg.leaking),
                      "—" if seg.leak_flow is None else f"{seg.leak_flow * _LPM:.3f}",
                      "—" if seg.size is None else f"{seg.size * 1e9:.3f}",
                      f"{seg.theta[0]:.1f}-{seg.theta[1]:.1f}")
    return table


def cycle_table(a: PumpLeakResponse) -> Table:
    """Every cycle: its series, oil temperature, pressure, flow, leak and whether it leaks."""
    table = Table("series", "name", r"oil \[°C]", r"pressure \[bar]", rf"flow \[{_FLOW}]",
                  rf"deficit \[{_FLOW}]", rf"leak \[{_FLOW}]", "leaking", title="cycles")
    for c in a.cycles:
        table.add_row("—" if c.series_id is None else str(c.series_id), escape(c.name),
                      f"{c.oil_temperature:.1f}", f"{c.pressure / 1e5:.1f}",
                      f"{c.flow * _LPM:.3f}", f"{c.deficit * _LPM:+.3f}",
                      "—" if c.leak_flow is None else f"{c.leak_flow * _LPM:+.3f}",
                      "yes" if c.leaking else "")
    return table


def register(cli: typer.Typer) -> None:
    """Add ``pump-leak`` to the ``hydrodiag`` command."""
    cli.command("pump-leak")(pump_leak_command)
