"""Channels a reader does not know: the note that says so, with the nearest known name.

A column map's typo (``P_pmup`` for ``P_pump``, ``Q_meter_b`` for ``Q_meter_B``) or a
misspelt export header (``Ppump [Pa]``) kept the channel under its wrong name, and the
readers skipped it without a word: the diagnosis of a worn spool fell from p 0.89 to 0.54
(a library user's pass).  The HTTP import and the CLI said so in their own layer; the rule
and its note are here, once, for them (:mod:`app.services.rig_channels`) and for the
library's readers (:func:`diagnostics.timeseries.read_series`,
:func:`diagnostics.cycle_readings.cycle_readings`).

A channel is *unknown* when it is none of the rig model's outputs, none of the condition
channels (:data:`CONDITION_CHANNELS`) and none of the extra channels a reader takes (a
pump flow meter, :data:`PUMP_FLOW_CHANNEL`).  Unknown channels are kept as
given (a logger's own extra signal is no error), and noted.  A reader without the rig
checks against what it can know: a cycle's readings against the cylinder-cycle circuit's
outputs (:func:`cycle_model_channels`), which they read; ``read_series``, which reads any
rig's series, against the outputs of every rig model hydrodiag builds
(:func:`any_model_channels`: a name none of them has is no rig's channel; ``read_series``
stayed silent there, a review's leftover).
"""

from __future__ import annotations

import difflib
from collections.abc import Collection, Iterable, Mapping, Sequence
from functools import lru_cache

__all__ = ["CONDITION_CHANNELS", "PUMP_FLOW_CHANNEL", "any_model_channels",
           "cycle_model_channels", "nearest_channel", "series_channel_notes",
           "unknown_channel_note", "unknown_channels"]

#: Condition channels and their SI unit (°C for temperature, as everywhere in hydrodiag).
CONDITION_CHANNELS: dict[str, str] = {
    "load": "N", "back_pressure": "Pa", "oil_temperature": "degC", "pump_speed": "rad/s",
}
#: a pump flow meter's channel [m³/s]: read by a cycle's readings, though no output of the
#: rig's model (meter B plus a relief flow would count meter B twice)
PUMP_FLOW_CHANNEL = "Q_pump"


@lru_cache(maxsize=1)
def cycle_model_channels() -> tuple[str, ...]:
    """The outputs of the cylinder-cycle circuit's model (paper 002's rig, without effects),
    in the model's order: the names a cycle's channels take when the caller has no rig."""
    from sim.rigs.assembly import build_graph
    from sim.rigs.circuits import CIRCUITS

    name = next(c.name for c in CIRCUITS.values() if c.cycle)
    return tuple(build_graph(name)[0].outputs)


def any_model_channels() -> tuple[str, ...]:
    """The outputs of every rig model hydrodiag builds, sorted: each registered circuit
    (:data:`sim.rigs.circuits.CIRCUITS`) alone and with each library effect that applies
    to it (a rig's model is its circuit's graph with its effects).  The names a channel of
    some rig's model takes, for a reader that has no rig."""
    from sim.components.effects import effects_for
    from sim.rigs.circuits import CIRCUITS

    return _model_channels(tuple((name, tuple(effects_for(name))) for name in CIRCUITS))


@lru_cache(maxsize=4)
def _model_channels(circuits: tuple[tuple[str, tuple[str, ...]], ...]) -> tuple[str, ...]:
    """:func:`any_model_channels` of these (circuit, its effects), cached: a circuit
    registered later reads anew."""
    from sim.rigs.assembly import build_graph_with_effects
    from sim.rigs.circuits import get_circuit

    names: set[str] = set()
    for name, effects in circuits:
        circuit = get_circuit(name)
        for added in ((), *((e,) for e in effects)):
            names.update(build_graph_with_effects(circuit, added)[0].outputs)
    return tuple(sorted(names))


def nearest_channel(name: str, known: Iterable[str]) -> str | None:
    """The known channel ``name`` was likely meant to be: one differing in case only, else
    the closest by :func:`difflib.get_close_matches` (similarity ≥ 0.6), else None."""
    names = sorted(set(known))
    same = [k for k in names if k.lower() == name.lower() and k != name]
    if same:
        return same[0]
    close = difflib.get_close_matches(name, names, n=1)
    return close[0] if close else None


def unknown_channels(names: Iterable[str], known: Collection[str]) -> list[str]:
    """``names`` that are none of ``known`` and no condition channel, sorted."""
    return sorted(set(names) - set(known) - set(CONDITION_CHANNELS))


def unknown_channel_note(unknown: Collection[str], model: Collection[str], consequence: str,
                         *, also: Collection[str] = (), whose: str = "the rig's model") -> str:
    """The note on ``unknown`` channels: "channel(s) … are not channels of ``whose`` (its
    ``model`` channels): ``consequence``", then a "did you mean" for each with a near name
    among ``model`` and ``also`` (channels read besides the model's)."""
    hints = [f"{near!r} for {name!r}" for name in unknown
             if (near := nearest_channel(name, (*model, *also))) is not None]
    return (f"channel(s) {', '.join(unknown)} are not channels of {whose} "
            f"({', '.join(model)}): {consequence}"
            + (f"; did you mean {', '.join(hints)}?" if hints else ""))


def series_channel_notes(channels: Sequence[str], expected: Mapping[str, str] | None
                         ) -> tuple[str, ...]:
    """The notes of :func:`diagnostics.timeseries.read_series` on the channels it read:
    one on ``channels`` that are none of the rig's (``expected``, channel → SI unit) or,
    without them, of any rig model hydrodiag builds (:func:`any_model_channels`: no rig
    has another), and no condition or pump flow meter; empty when there are none."""
    if expected:
        model = [c for c in expected if c not in CONDITION_CHANNELS]
        whose, which, check = "the rig's model", "the rig", ""
    else:
        model = list(any_model_channels())
        whose, which = "any rig model hydrodiag builds", "a rig"
        check = " (expected=rig.channels() checks against the rig's own)"
    unknown = unknown_channels(channels, (*model, PUMP_FLOW_CHANNEL))
    if not unknown:
        return ()
    return (unknown_channel_note(
        unknown, model, f"read as given, but no reader of {which} compares with them; a "
        f"misspelt name is read again with the column map or the column's name corrected"
        f"{check}", also=(PUMP_FLOW_CHANNEL,), whose=whose),)
