"""The discrepancy workflow's first step (:mod:`diagnostics.discrepancy.workflow`): the
records checked and prepared before any re-simulation.

The rig's document validated and its cycle required; phases read off the position where
a record has none and the speed derived where it logs only the position
(:mod:`~diagnostics.discrepancy.records`), each with a note; the records' units and clock
checked against the rig (a pressure in bar under ``[Pa]``, l/min under ``[m^3/s]``, a
sample rate that cannot be right: :mod:`diagnostics.time_scale`); the training / held-out
split; the training records' signals and the junction balances evaluated on them
(:mod:`~diagnostics.discrepancy.balances`); each channel's noise, coloured or white
(:mod:`~diagnostics.discrepancy.noise`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from diagnostics.discrepancy.balances import BalanceData, balance_data
from diagnostics.discrepancy.noise import (
    Noise,
    coloured_note,
    noise_models,
    propagated_floors,
    with_noise,
)
from diagnostics.discrepancy.records import (
    check_motion_and_flow_units,
    check_pressure_units,
    require_cycle_records,
    unread_notes,
    with_phases,
    with_velocity,
)
from diagnostics.discrepancy.selection import require_samples
from diagnostics.discrepancy.signals import Signals, condition_of, prepare, same_channels
from diagnostics.discrepancy.simulate import timed_switch
from diagnostics.observations import rig_limits
from diagnostics.time_scale import time_scale_notes
from diagnostics.timeseries import SeriesRecord
from sim.errors import CircuitError, InputError
from sim.rigs.assembly import Rig
from sim.rigs.schema import validate_rig_document

__all__ = ["OUTPUTS", "FirstStep", "check_arguments", "check_document", "check_records",
           "first_step", "split", "step_noise"]

#: measured channels compared in output-error form, when present
OUTPUTS = ("P1", "P2", "v", "P_pump", "P_valve_P", "Q_meter_B", "Q_meter_C")


#: records of a kind within these of its edge record's load [-, relative] and oil
#: temperature [K] repeat the edge condition and are held out with it
EDGE_LOAD_REL, EDGE_TEMPERATURE_K = 0.05, 2.0
#: records of a kind left to train on when the edge and its repeats are held out [-]
MIN_TRAINING = 2


def split(records: Sequence[SeriesRecord], rig: Rig) -> tuple[list[int], list[int], list[str]]:
    """Training and held-out record indices, and notes: per kind of stroke (full strokes,
    timed slow strokes) that has at least two records, the edge record (highest load, then
    highest temperature) and every repeat of its condition (within :data:`EDGE_LOAD_REL`
    of its load and :data:`EDGE_TEMPERATURE_K` of its temperature).

    The check on held-out records is then an extrapolation to the edge of the operating
    range, which is what exposes an effect from outside the library named with confidence
    (design notes, "hold out the edge of the operating range"); a repeat of the edge left in
    training made it an interpolation (a design pass).  Where that would leave fewer than
    :data:`MIN_TRAINING` records of the kind to train on (every record repeating one
    condition, or three of four), the edge record alone is held out and a note says the
    check interpolates.
    """
    if len(records) < 2:
        return [0], [], []
    conditions = [condition_of(r, rig) for r in records]
    key = [(c.load, c.oil_temperature) for c in conditions]
    timed = [timed_switch(r, rig) is not None for r in records]
    held: list[int] = []
    notes: list[str] = []
    for kind in (False, True):
        mine = [i for i in range(len(records)) if timed[i] == kind]
        if len(mine) < 2:
            continue
        edge = max(mine, key=lambda i: key[i])
        load, temperature = key[edge]
        repeats = [i for i in mine if abs(key[i][0] - load) <= EDGE_LOAD_REL * abs(load)
                   and abs(key[i][1] - temperature) <= EDGE_TEMPERATURE_K]
        if len(repeats) == 1 or len(mine) - len(repeats) >= MIN_TRAINING:
            held += repeats
            continue
        held.append(edge)
        stroke = "timed" if kind else "full"
        if len(repeats) == len(mine):
            notes.append(f"every {stroke}-stroke record is at one condition ({load:g} N, "
                         f"{temperature:g} °C): record {records[edge].name!r} is held out, "
                         "so the held-out check interpolates; records at another load or "
                         "temperature make it an extrapolation to the edge of the "
                         "operating range")
        else:
            # all of them out left one record to train on, and a hidden seal friction the
            # one-record hold-out named went unnamed (a verification pass)
            notes.append(f"{len(repeats)} of the {len(mine)} {stroke}-stroke records repeat "
                         f"the edge condition ({load:g} N, {temperature:g} °C): record "
                         f"{records[edge].name!r} alone is held out so that "
                         f"{MIN_TRAINING} or more train, and the held-out check interpolates "
                         "between its repeats")
    if not held:
        held = [max(range(len(records)), key=lambda i: key[i])]
    return [i for i in range(len(records)) if i not in held], sorted(held), notes


def check_document(rig_document: object) -> None:
    """Refuse a ``rig_document`` that is no mapping, naming ``rig_document``: a compiled
    :class:`~sim.rigs.Rig` raised "'Rig' object is not iterable" and a file's path
    "dictionary update sequence element #0 …" (a library user's pass)."""
    if isinstance(rig_document, Rig):
        hint = "its compiled Rig: pass rig.spec.to_document()"
    elif isinstance(rig_document, str | Path):
        hint = "a path: read it with sim.rigs.load_rig_document(path)"
    elif not isinstance(rig_document, Mapping):
        hint = f"a {type(rig_document).__name__}"
    else:
        return
    raise InputError(f"the workflow starts from the rig's document (a mapping), not {hint}",
                     field="rig_document")


def check_arguments(rig_document: object, records: object) -> None:
    """:func:`check_document`, and refuse ``records`` that are not a list of
    :class:`~diagnostics.timeseries.SeriesRecord` (one record alone raised "'SeriesRecord'
    object is not iterable", where ``diagnose`` said what to pass: a library user's pass),
    naming ``records`` (also when empty) or ``records[i]``."""
    check_document(rig_document)
    if isinstance(records, SeriesRecord):
        raise InputError("records is a list of records: discover(rig_document, [record])",
                         field="records")
    if not isinstance(records, Sequence) or isinstance(records, str | bytes):
        raise InputError(f"records is a list of SeriesRecord (diagnostics.timeseries."
                         f"read_series), not a {type(records).__name__}", field="records")
    if not records:   # named "file" (the upload's field) in the library, not the argument
        raise InputError("no records to analyse: give at least one measured cycle "
                         "(diagnostics.timeseries.read_series)", field="records")
    for i, record in enumerate(records):
        if not isinstance(record, SeriesRecord):
            raise InputError(f"records are SeriesRecord objects (diagnostics.timeseries."
                             f"read_series), not a {type(record).__name__}",
                             field=f"records[{i}]")


def check_records(rig_document: Mapping[str, Any], records: Sequence[SeriesRecord]) -> None:
    """Raise what the workflow's first step would raise on these records (no phases and no
    position to read them off, an unstated condition, no balance computable, too few
    usable samples), in ~0.1 s per 15,000 samples and before any simulation:
    ``POST /discrepancy`` answers 422 instead of accepting a job that fails."""
    first_step(rig_document, records)


@dataclass
class FirstStep:
    """The workflow's first step: the rig, the records (phases read off the position
    where they had none, and the notes saying so), the training/held-out split, the
    training records' prepared signals and the balances evaluated on them."""

    rig: Rig
    records: list[SeriesRecord]
    notes: list[str]
    train_i: list[int]
    held_i: list[int]
    signals: Signals
    data: list[BalanceData]


def first_step(rig_document: Mapping[str, Any], records: Sequence[SeriesRecord]
                ) -> FirstStep:
    """:class:`FirstStep` of the records, each balance with enough usable samples."""
    check_arguments(rig_document, records)
    rig = Rig.from_spec(validate_rig_document(dict(rig_document)))
    try:
        rig.require_cycle("the discrepancy workflow on measured cycles")
    except CircuitError as exc:  # the same file, once imported, is read (an analyst's pass)
        raise CircuitError(f"{exc.message} A time series of it is read by its pump's "
                           "plateaus once stored: import it (hydrodiag import series, POST "
                           "/rigs/{id}/series) and run the workflow on the stored series "
                           "(--series, series_ids)", field=exc.field) from None
    labelled, notes = with_phases(records, rig.values()["cylinder.stroke"])
    labelled, derived = with_velocity(labelled)
    notes += derived
    # every record's outputs, not only the training ones prepare() sees: a held-out record
    # without 'v' failed the job later with KeyError (a fleet integrator's pass)
    same_channels(labelled, OUTPUTS)
    require_cycle_records(labelled)
    values = rig.values()
    check_pressure_units(labelled, values["cylinder.A1"], values.get("cylinder.Fu"))
    check_motion_and_flow_units(labelled, stroke=values["cylinder.stroke"],
                                delivery=values["pump.speed"] * values["pump.Vp"])
    # a clock that cannot be right (a wrong sample rate): said as the import says it
    notes += time_scale_notes(records, rig_limits(rig))
    train_i, held_i, held_notes = split(labelled, rig)
    notes += held_notes
    signals = prepare([labelled[i] for i in train_i], rig)
    data = balance_data(signals, values)
    if not data:
        raise InputError("the records lack the channels of every balance (need e.g. P1, P2, v "
                         "for the piston force, or Q_meter_B, P_pump for the pump)",
                         field="file")
    for d in data:
        require_samples(d)
    notes += unread_notes(labelled, [d.balance.name for d in data], OUTPUTS)
    return FirstStep(rig, labelled, notes, train_i, held_i, signals, data)


def step_noise(first: FirstStep, channels: Sequence[str]) -> tuple[dict[str, Noise], str]:
    """Each channel's noise (:mod:`~diagnostics.discrepancy.noise`); where any is
    coloured, the balances' noise floors from a surrogate of it (set on ``first.data``)
    and the note saying so, else ''."""
    models = noise_models(first.records, channels)
    if not any(n.coloured for n in models.values()):
        return models, ""
    train = [first.records[i] for i in first.train_i]
    noisy = prepare(with_noise(train, models), first.rig)
    floors = propagated_floors(first.data, first.signals, noisy, first.rig.values())
    for d in first.data:
        d.noise_floor = max(d.noise_floor, floors.get(d.balance.name, 0.0))
    derived = {c for r in first.records for c in (r.metadata or {}).get("derived", [])}
    return models, coloured_note(models, derived)
