"""Adapter for the ZeMA condition-monitoring rig (UCI "Condition monitoring of hydraulic systems").

Helwig, Pignanelli, Schütze, I2MTC-2015 (doi:10.1109/I2MTC.2015.7151267): 2205 constant
load cycles of 60 s on a test rig with a working and a cooling-filtration circuit; the
condition of cooler, valve, pump (internal leakage) and accumulator varied in steps.  The
files (``../shared/data/real/uci-hydraulic-zema/``, see its ``SOURCE.md``) are wide: one row
per cycle, one column per sample, one file per sensor, no header, no time column.

This adapter turns them into the project's one import format
(:mod:`diagnostics.timeseries`): a long table with a ``record`` column (``cycle-<n>``, 1-based
cycle number as in ``profile.txt``), channels named by role with their units given by the
column map :data:`COLUMN_MAP`, and the sample rate of the files (1 Hz for the 1-second block
means of ``data_compressed_1hz/`` and the raw ``TS*.txt``; 100 Hz for the few raw cycles
of ``fullres_samples/``, :func:`read_fullres`).  The records come back as
:class:`~diagnostics.timeseries.SeriesRecord` marked measured.  The labels (``profile.txt``)
are returned separately as :class:`ZemaLabels`; they are for scoring only.

Sensor → channel (units from ``description.txt`` / ``SOURCE.md``):

=======  ===================  =======  ==========================================
sensor   channel              unit     role
=======  ===================  =======  ==========================================
PS1      ``p_pump``           bar      pressure at the pump outlet (working circuit)
PS2      ``p_work``           bar      working-circuit pressure behind the valve
FS1      ``q_work``           l/min    working-circuit volume flow
EPS1     ``motor_power``      W        electric power of the pump's motor
TS1      ``oil_temperature``  °C       oil temperature (varies within a cycle: a channel)
TS2-4    ``temperature_ts2``  °C       the rig's other oil temperatures (``_ts3``, ``_ts4``)
=======  ===================  =======  ==========================================
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pandas as pd

from diagnostics.timeseries import SeriesRecord, series_from_frame
from sim.errors import InputError

__all__ = ["CIRCUIT", "COLUMN_MAP", "CYCLE_S", "DEFAULT_SENSORS", "FULLRES_CYCLES", "FULLRES_FILE",
           "NATIVE_RATES",
           "OTHER_TEMPERATURES", "SENSOR_FILES", "ZemaCycles",
           "ZemaLabels", "cycles_frame", "find_shared", "load_1hz", "load_fullres", "read_fullres",
           "read_records", "zema_root"]

Arr = npt.NDArray[np.float64]

#: Raw sensor name → (channel, unit) of the import's column map.
COLUMN_MAP: dict[str, tuple[str, str]] = {
    "PS1": ("p_pump", "bar"),
    "PS2": ("p_work", "bar"),
    "FS1": ("q_work", "l/min"),
    "EPS1": ("motor_power", "W"),
    "TS1": ("oil_temperature", "degC"),
}

#: The rig's other oil temperatures (read on request, e.g. to compare sensors).
OTHER_TEMPERATURES: dict[str, tuple[str, str]] = {
    "TS2": ("temperature_ts2", "degC"),
    "TS3": ("temperature_ts3", "degC"),
    "TS4": ("temperature_ts4", "degC"),
}

#: Sensor → file of the 1 Hz set, relative to the data set's folder.
SENSOR_FILES: dict[str, str] = {
    "PS1": "data_compressed_1hz/PS1_normalized.csv",
    "PS2": "data_compressed_1hz/PS2_normalized.csv",
    "FS1": "data_compressed_1hz/FS1_normalized.csv",
    "EPS1": "data_compressed_1hz/EPS1_normalized.csv",
    "TS1": "TS1.txt",
    "TS2": "TS2.txt",
    "TS3": "TS3.txt",
    "TS4": "TS4.txt",
}

#: The circuit of the rig the cycles belong to (``sim/rigs/zema.yaml``): pump, relief,
#: the working line's orifice and accumulator; its records carry the channels above.
CIRCUIT = "pump-relief-orifice"

#: Sensors read by default: the working circuit's pressures, flow, motor power, TS1.
DEFAULT_SENSORS: tuple[str, ...] = ("PS1", "PS2", "FS1", "EPS1", "TS1")

#: Samples per cycle in the 1 Hz files [-] (60 s cycles at 1 Hz).
SAMPLES_1HZ = 60
#: Length of one load cycle [s]; the data set's cycles follow one another.
CYCLE_S = 60.0


def find_shared() -> Path:
    """The shared data folder: ``$HYDRODIAG_SHARED``, else ``<repo>/../shared``, else ``/work/shared``.

    Raises
    ------
    InputError
        None of them exists (``field="HYDRODIAG_SHARED"``).
    """
    repo = Path(__file__).resolve().parents[2]
    candidates = [os.environ.get("HYDRODIAG_SHARED"), str(repo.parent / "shared"),
                  "/work/shared"]
    for c in candidates:
        if c and Path(c).is_dir():
            return Path(c)
    raise InputError("shared data not found: set HYDRODIAG_SHARED to the folder holding "
                     "data/real/", field="HYDRODIAG_SHARED")


def zema_root() -> Path:
    """Folder of the ZeMA data set inside the shared data."""
    return find_shared() / "data" / "real" / "uci-hydraulic-zema"


@dataclass(frozen=True)
class ZemaLabels:
    """Condition labels of ``profile.txt`` (for scoring only, never for fitting).

    Attributes
    ----------
    cycle
        1-based cycle numbers [-].
    cooler
        Cooler efficiency [%]: 3 / 20 / 100.
    valve
        Valve switching condition [%]: 100 / 90 / 80 / 73.
    leakage
        Internal pump leakage class [-]: 0 none, 1 weak, 2 severe.
    accumulator
        Accumulator pre-charge [bar]: 130 / 115 / 100 / 90.
    stable
        1 where static conditions may not have been reached yet [-].
    """

    cycle: npt.NDArray[np.int64]
    cooler: Arr
    valve: Arr
    leakage: Arr
    accumulator: Arr
    stable: Arr

    def take(self, idx: npt.ArrayLike) -> ZemaLabels:
        """The labels at positions ``idx``."""
        i = np.asarray(idx)
        return ZemaLabels(self.cycle[i], self.cooler[i], self.valve[i], self.leakage[i],
                          self.accumulator[i], self.stable[i])


@dataclass(frozen=True)
class ZemaCycles:
    """Wide per-cycle arrays as read from the files: sensor → (cycles × samples) [file units]."""

    cycles: npt.NDArray[np.int64]
    sensors: dict[str, Arr]
    sample_rate: float

    def between(self, first: int, last: int) -> ZemaCycles:
        """The cycles numbered ``first`` to ``last`` (1-based, both included)."""
        keep = (self.cycles >= first) & (self.cycles <= last)
        return ZemaCycles(self.cycles[keep], {k: v[keep] for k, v in self.sensors.items()},
                          self.sample_rate)


def _read_wide(path: Path, rows: npt.NDArray[np.int64] | None) -> Arr:
    try:
        frame = pd.read_csv(path, sep="\t", header=None, dtype=np.float64)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read {path.name}: {exc}", field=path.name) from None
    arr = frame.to_numpy(dtype=np.float64)
    return arr if rows is None else arr[rows]


def load_1hz(root: Path | None = None, cycles: Sequence[int] | None = None,
             sensors: Sequence[str] = DEFAULT_SENSORS) -> tuple[ZemaCycles, ZemaLabels]:
    """The 1 Hz files and labels of ``cycles`` (1-based; all when None) for ``sensors``.

    Raises
    ------
    InputError
        A file is missing or unreadable, a cycle number out of range, or a file without
        60 samples per cycle (the error names the file).
    """
    base = root or zema_root()
    prof = _read_wide(base / "profile.txt", None)
    n = prof.shape[0]
    rows = None if cycles is None else np.asarray(cycles, dtype=np.int64) - 1
    if rows is not None and (rows.size == 0 or rows.min() < 0 or rows.max() >= n):
        raise InputError(f"cycle numbers must lie in 1..{n}", field="cycles")
    data: dict[str, Arr] = {}
    for s in sensors:
        if s not in SENSOR_FILES:
            raise InputError(f"unknown sensor {s!r} (known: {', '.join(SENSOR_FILES)})",
                             field="sensors")
        arr = _read_wide(base / SENSOR_FILES[s], rows)
        if arr.shape[1] != SAMPLES_1HZ:
            raise InputError(f"{arr.shape[1]} samples per cycle, expected {SAMPLES_1HZ}",
                             field=SENSOR_FILES[s])
        data[s] = arr
    idx = np.arange(n) if rows is None else rows
    p = prof[idx]
    labels = ZemaLabels(idx.astype(np.int64) + 1, p[:, 0], p[:, 1], p[:, 2], p[:, 3], p[:, 4])
    return ZemaCycles(idx.astype(np.int64) + 1, data, 1.0), labels


def cycles_frame(data: ZemaCycles) -> pd.DataFrame:
    """The wide arrays as one long table in the import format (no time column)."""
    n_cyc = data.cycles.size
    first = next(iter(data.sensors.values()))
    per = first.shape[1]
    cols: dict[str, object] = {"record": np.repeat([f"cycle-{c}" for c in data.cycles], per)}
    for s, arr in data.sensors.items():
        if arr.shape != (n_cyc, per):
            raise InputError(f"shape {arr.shape}, expected {(n_cyc, per)}", field=s)
        cols[s] = arr.reshape(-1)
    return pd.DataFrame(cols)


def read_records(data: ZemaCycles,
                 progress: Callable[[int, int], None] | None = None) -> list[SeriesRecord]:
    """One measured :class:`SeriesRecord` per cycle, through :func:`series_from_frame`.

    ``progress(done, total)`` is called after each block of cycles (for a progress bar).
    """
    known = {**COLUMN_MAP, **OTHER_TEMPERATURES}
    cmap = {s: known[s] for s in data.sensors}
    out: list[SeriesRecord] = []
    total = data.cycles.size
    block = 100
    for a in range(0, total, block):
        part = ZemaCycles(data.cycles[a:a + block],
                          {k: v[a:a + block] for k, v in data.sensors.items()}, data.sample_rate)
        out.extend(series_from_frame(cycles_frame(part), name="zema", column_map=cmap,
                                     sample_rate=data.sample_rate, measured=True,
                                     metadata={"source": "ZeMA hydraulic rig (UCI), "
                                                         f"{data.sample_rate:g} Hz"}))
        if progress is not None:
            progress(min(a + block, total), total)
    return out


#: Native sampling rates of the raw UCI files [Hz] (``description.txt``).
NATIVE_RATES: dict[str, float] = {"PS1": 100.0, "PS2": 100.0, "EPS1": 100.0, "FS1": 10.0,
                                  "TS1": 1.0}

#: Cycle numbers (1-based) of the rows of ``fullres_samples/jeremiafourie/testing_sample.csv``
#: (identified by exact match against the 1 Hz files, ``SOURCE.md``).
FULLRES_CYCLES: tuple[int, ...] = (1967, 1092, 1469, 439, 1791, 1954, 753, 409, 1478, 2038)
#: The raw cycles at the native rates, relative to the data set's folder (``SOURCE.md``).
FULLRES_FILE = "fullres_samples/jeremiafourie/testing_sample.csv"


def read_fullres(path: Path, cycles: Sequence[int] | None = None,
                 sensors: Sequence[str] | None = None,
                 duration: float | None = None) -> list[SeriesRecord]:
    """Records at the native rate from the wide full-resolution layout: :func:`load_fullres`
    (its parameters and errors) through :func:`read_records`."""
    return read_records(load_fullres(path, cycles, sensors, duration))


def load_fullres(path: Path, cycles: Sequence[int] | None = None,
                 sensors: Sequence[str] | None = None,
                 duration: float | None = None) -> ZemaCycles:
    """Cycles at the native rate from the wide full-resolution layout (``<SENSOR>_<k>`` columns).

    The record's time base is that of the fastest sensor given (100 Hz with PS1); slower
    sensors are held between their samples (zero-order hold: a 10 Hz flowmeter reading is
    the value for the next 0.1 s), so every channel has one value per sample.

    Parameters
    ----------
    path
        CSV with a header ``PS1_0 … PS1_5999, …`` and one row per cycle.
    cycles
        Cycle number (1-based) of each row, for the record names; None: the data set's
        own file's rows (:data:`FULLRES_CYCLES`), for a file of that many rows.
    sensors
        Sensors to read (keys of :data:`NATIVE_RATES`); None: those of
        :data:`DEFAULT_SENSORS` that the file has (a ``<SENSOR>_0`` column).
    duration
        Seconds of each cycle to read from its start [s]; None: all that the fastest sensor
        holds (60 s in the data set's file).

    Raises
    ------
    InputError
        Missing columns (the error names the first), a row count that differs from
        ``cycles`` (or, without them, from :data:`FULLRES_CYCLES`), no known sensor, or a
        sensor whose samples do not span ``duration``.
    """
    try:
        frame = pd.read_csv(path)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read {Path(path).name}: {exc}", field="file") from None
    if cycles is None:
        if len(frame) != len(FULLRES_CYCLES):
            raise InputError(f"{len(frame)} rows: give each row's cycle number (the data "
                             f"set's own file has {len(FULLRES_CYCLES)}, cycles "
                             f"{', '.join(map(str, FULLRES_CYCLES))})", field="cycles")
        cycles = FULLRES_CYCLES
    if len(frame) != len(cycles):
        raise InputError(f"{len(frame)} rows but {len(cycles)} cycle numbers", field="cycles")
    if sensors is None:
        sensors = [s for s in DEFAULT_SENSORS if f"{s}_0" in frame.columns]
        if not sensors:
            raise InputError(f"no sensor column of {', '.join(DEFAULT_SENSORS)} (PS1_0 ...)",
                             field="file")
    unknown = [s for s in sensors if s not in NATIVE_RATES]
    if unknown:
        raise InputError(f"unknown sensor {unknown[0]!r} (known: {', '.join(NATIVE_RATES)})",
                         field="sensors")
    rate = max(NATIVE_RATES[s] for s in sensors)
    if duration is None:
        fastest = max(sensors, key=NATIVE_RATES.__getitem__)
        held = sum(1 for c in frame.columns if str(c).startswith(f"{fastest}_"))
        duration = held / rate
    n = round(duration * rate)
    wide: dict[str, Arr] = {}
    for s in sensors:
        k = round(duration * NATIVE_RATES[s])
        cols = [f"{s}_{i}" for i in range(k)]
        missing = [c for c in cols if c not in frame.columns]
        if missing or k == 0 or n % k:
            raise InputError(f"column missing ({len(missing)} of {k} for {s}: the sensors "
                             f"must span the same {duration:g} s)",
                             field=missing[0] if missing else f"{s}_0")
        arr = frame[cols].to_numpy(dtype=np.float64)
        wide[s] = np.repeat(arr, n // k, axis=1)
    return ZemaCycles(np.asarray(cycles, dtype=np.int64), wide, rate)
