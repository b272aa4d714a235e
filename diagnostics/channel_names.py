"""Channels a reader does not know: the note that says so, with the nearest known name.

A column map's typo (``P_pmup`` for ``P_pump``, ``Q_meter_b`` for ``Q_meter_B``) or a
misspelt export header (``Ppump [Pa]``) kept the channel under its wrong name, and the
readers skipped it without a word: the diagnosis of a worn spool fell from p 0.89 to 0.54
(a library user's pass).  The HTTP import and the CLI said so in their own layer; the rule
and its note are here, once, for them (:mod:`app.services.rig_channels`) and for the
library's readers (:func:`diagnostics.timeseries.read_series` given the rig's channels,
:func:`diagnostics.cycle_readings.cycle_readings`).

A channel is *unknown* when it is none of the rig model's outputs, none of the condition
channels (:data:`CONDITION_CHANNELS`) and none of the extra channels a reader takes (a
pump flow meter, :data:`PUMP_FLOW_CHANNEL`).  Unknown channels are kept as
given (a logger's own extra signal is no error), and noted.
"""

from __future__ import annotations

import difflib
from collections.abc import Collection, Iterable
from functools import lru_cache

__all__ = ["CONDITION_CHANNELS", "PUMP_FLOW_CHANNEL", "cycle_model_channels", "nearest_channel",
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
                         *, also: Collection[str] = ()) -> str:
    """The note on ``unknown`` channels: "channel(s) … are not channels of the rig's model
    (its ``model`` channels): ``consequence``", then a "did you mean" for each with a
    near name among ``model`` and ``also`` (channels read besides the model's)."""
    hints = [f"{near!r} for {name!r}" for name in unknown
             if (near := nearest_channel(name, (*model, *also))) is not None]
    return (f"channel(s) {', '.join(unknown)} are not channels of the rig's model "
            f"({', '.join(model)}): {consequence}"
            + (f"; did you mean {', '.join(hints)}?" if hints else ""))
