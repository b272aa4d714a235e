"""One measured record of time series in SI (:class:`SeriesRecord`), the unit conversion the
readers apply to each column (:func:`si_factor`) and the clock time a record starts at
(:func:`clock_time`); the readers are :mod:`diagnostics.timeseries`'."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from diagnostics.channel_names import CONDITION_CHANNELS
from sim.errors import InputError
from sim.units import UNITS, spelled

__all__ = ["SeriesRecord", "clock_time", "si_factor"]

Arr = npt.NDArray[np.float64]


def si_factor(unit: str, *, column: str, expected: str | None = None) -> tuple[str, float, float]:
    """``(canonical unit, scale, offset)`` taking a value in ``unit`` to SI.

    ``si = value·scale + offset``.  With ``expected`` the unit must be of that dimension.

    Raises
    ------
    InputError
        ``unit`` is unknown, or not of the ``expected`` dimension (``field=column``).
    """
    u = spelled(unit)
    if u == "K" and expected in (None, "degC"):
        return "degC", 1.0, -273.15
    candidates = [expected] if expected is not None else list(UNITS)
    for canonical in candidates:
        table = UNITS.get(canonical, {})
        if u in table:
            return canonical, table[u], 0.0
    if expected is not None:
        accepted = ", ".join(sorted(UNITS.get(expected, {expected: 1.0})))
        raise InputError(f"unit {u!r} is not a unit of this channel (expected {expected}; "
                         f"accepted: {accepted})", field=column)
    raise InputError(f"unknown unit {u!r}; write the unit in brackets, e.g. 'P1 [bar]', "
                     f"in one of: {', '.join(sorted({k for t in UNITS.values() for k in t}))}",
                     field=column)


@dataclass(frozen=True, eq=False)
class SeriesRecord:
    """One measured record: channels sampled at increasing times.

    Attributes
    ----------
    name
        Record identifier (the ``record`` column's value, or the source's name).
    t
        Sample times [s], strictly increasing.
    channels
        Channel name → values [SI unit of :attr:`units`].
    units
        Channel name → SI unit (``"Pa"``, ``"m^3/s"``, ``"degC"`` ...).
    phase
        Phase label per sample (``"working"``, ``"return"``), or ``None``.
    condition
        Operating condition constant over the record: ``load`` [N], ``back_pressure`` [Pa],
        ``oil_temperature`` [°C], ``pump_speed`` [rad/s] — those that are known.
    metadata
        The file's header entries (rig, fault, summary ...) as parsed JSON.
    measured
        True for data read from a file (the default); generated data sets it False.
    started_at
        Clock time at which ``t`` reads 0 [UTC], None when the source does not say.
    notes
        What the reading found that a user must know: channels that are not the rig's
        (read with the rig's channels, ``expected``; without them, no rig model's), with
        the nearest known name.
    """

    name: str
    t: Arr
    channels: dict[str, Arr]
    units: dict[str, str]
    phase: npt.NDArray[np.str_] | None = None
    condition: dict[str, float] = field(default_factory=dict)
    metadata: dict[str, Any] = field(default_factory=dict)
    measured: bool = True
    started_at: datetime | None = None
    notes: tuple[str, ...] = ()

    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def sample_rate(self) -> float | None:
        """Samples per second [Hz] when the sampling is uniform (steps within 1 %), else None.

        The rate is the number of steps over the span, given to 12 significant digits: a
        logger's times written to the millisecond read 1000 Hz, not 999.99999999 Hz."""
        dt = np.diff(self.t)
        if dt.size == 0:
            return None
        med = float(np.median(dt))
        if med <= 0 or float(np.max(np.abs(dt - med))) > 0.01 * med:
            return None
        return float(f"{dt.size / float(self.t[-1] - self.t[0]):.12g}")

    @property
    def measured_at(self) -> datetime | None:
        """Clock time of the first sample [UTC]: :attr:`started_at` plus ``t[0]``; None
        without a start."""
        if self.started_at is None:
            return None
        return self.started_at + timedelta(seconds=float(self.t[0]))

    @property
    def duration(self) -> float:
        """Time from the first to the last sample [s]."""
        return float(self.t[-1] - self.t[0])

    def channel(self, name: str) -> Arr:
        """Values of channel ``name`` [SI]; :class:`InputError` naming it when absent."""
        if name not in self.channels:
            raise InputError(f"record {self.name!r} has no channel {name!r} (has: "
                             f"{', '.join(self.channels) or 'none'})", field=name)
        return self.channels[name]

    def window(self, start: float, stop: float) -> SeriesRecord:
        """The samples with ``start ≤ t ≤ stop`` [s], as a new record."""
        sel = (self.t >= start) & (self.t <= stop)
        return SeriesRecord(self.name, self.t[sel], {k: v[sel] for k, v in self.channels.items()},
                            dict(self.units), None if self.phase is None else self.phase[sel],
                            dict(self.condition), dict(self.metadata), self.measured,
                            self.started_at, self.notes)

    def frame(self) -> pd.DataFrame:
        """The record as a table in the import format (units in the column names); its
        condition entries that are not channels as constant condition columns
        (``load [N]`` ...), so that :func:`read_series` reads the condition back."""
        data: dict[str, Any] = {"t [s]": self.t}
        if self.phase is not None:
            data["phase"] = self.phase
        for k, v in self.channels.items():
            data[f"{k} [{self.units[k]}]"] = v
        for k, value in self.condition.items():
            if k in CONDITION_CHANNELS and k not in self.channels:
                data[f"{k} [{CONDITION_CHANNELS[k]}]"] = np.full(self.t.size, float(value))
        return pd.DataFrame(data)


def clock_time(value: object, *, field: str = "started_at") -> datetime:
    """A clock time given as ISO 8601 text with its zone (or an aware datetime), in UTC.

    Raises
    ------
    InputError
        Not a time, or a time without its zone (``field`` names where it was given).
    """
    if isinstance(value, datetime):
        when = value
    elif isinstance(value, str):
        try:
            when = datetime.fromisoformat(value.strip().replace("Z", "+00:00"))
        except ValueError:
            raise InputError(f"{value!r} is not an ISO 8601 time (e.g. 2026-11-20T08:00:00Z)",
                             field=field) from None
    else:
        raise InputError("give the time as ISO 8601 text (e.g. 2026-11-20T08:00:00Z)",
                         field=field)
    if when.tzinfo is None or when.utcoffset() is None:
        raise InputError("give the time with its zone (ISO 8601, e.g. ...Z or +01:00)",
                         field=field)
    return when.astimezone(UTC)
