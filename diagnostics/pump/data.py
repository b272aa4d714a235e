"""Steady pump test data (ISO 4409 test points) in SI units.

One row per steady test point.  Units inside: pressures [Pa] (gauge; only the difference
Δp = p_out − p_in enters the models), shaft speed ``omega`` [rad/s], oil temperature
``theta`` [°C], flow ``q`` [m³/s] (pump outlet), shaft torque ``torque`` [N·m].

Data from the virtual bench carry ``simulated=True`` and a provenance line; that flag
travels with the data through CSV (a ``# SIMULATED`` header line) so that virtual points are
never mistaken for measurements.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from diagnostics.measurement import (
    MAX_FLOW_READING,
    MAX_GAUGE_PRESSURE,
    MIN_GAUGE_PRESSURE,
    MIN_PRESSURE_READING,
    OIL_TEMPERATURE_RANGE,
)
from sim.errors import InputError, MeasurementError
from sim.rigs.assembly import MAX_PUMP_SPEED

#: Plausible range of each column [SI]: gauge pressures from vacuum to 10 kbar, speeds up to
#: ~19,000 rpm, the oil temperatures a record may state, delivered flow up to 1 m³/s
#: (60,000 l/min); a value outside is an error of the file, not a test point.
_PLAUSIBLE = (("p_in", MIN_GAUGE_PRESSURE, MAX_GAUGE_PRESSURE, "Pa"),
              ("p_out", MIN_GAUGE_PRESSURE, MAX_GAUGE_PRESSURE, "Pa"),
              ("omega", 0.0, MAX_PUMP_SPEED, "rad/s"),
              ("theta", *OIL_TEMPERATURE_RANGE, "degC"),
              ("q", 0.0, MAX_FLOW_READING, "m^3/s"))

__all__ = ["MAX_REPLICATE", "MIN_PRESSURE_RISE", "BenchData"]

#: smallest highest pressure rise of a bench table [Pa]: 0.1 bar; below it the pressures
#: are in another unit than their header says
MIN_PRESSURE_RISE = MIN_PRESSURE_READING

#: largest replicate number a table may carry [-]
MAX_REPLICATE = 10_000

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def _column(name: str, values: npt.ArrayLike, n: int | None) -> FloatArray:
    arr = np.asarray(values, dtype=np.float64).ravel()
    if n is not None and arr.size != n:
        raise InputError(f"{arr.size} values, expected {n}", field=name)
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise MeasurementError(f"value is NaN or infinite (data row {bad + 1})", field=name)
    return arr


@dataclass(frozen=True, eq=False)
class BenchData:
    """Steady pump test points in SI units.

    Parameters
    ----------
    p_in, p_out
        Inlet and outlet pressure [Pa] (gauge).
    omega
        Shaft speed [rad/s], > 0.
    theta
        Oil temperature at the pump inlet [°C].
    q
        Delivered (outlet) flow [m³/s], > 0.
    torque
        Shaft torque [N·m], or ``None`` when no torque transducer was fitted.
    replicate
        Replicate number of each point [-] (0 when unknown).
    simulated
        ``True`` for virtual-bench data (never to be reported as measured).
    provenance
        Free text: where the data come from.

    Raises
    ------
    InputError
        If columns differ in length or the data set is empty.
    MeasurementError
        If a value is NaN/inf, a speed or flow is not positive, or Δp < 0.
    """

    p_in: FloatArray
    p_out: FloatArray
    omega: FloatArray
    theta: FloatArray
    q: FloatArray
    torque: FloatArray | None = None
    replicate: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    simulated: bool = False
    provenance: str = ""

    def __post_init__(self) -> None:
        p_out = _column("p_out", self.p_out, None)
        n = p_out.size
        if n == 0:
            raise InputError("no test points", field="p_out")
        cols = {
            "p_in": _column("p_in", self.p_in, n),
            "p_out": p_out,
            "omega": _column("omega", self.omega, n),
            "theta": _column("theta", self.theta, n),
            "q": _column("q", self.q, n),
        }
        for name, arr in cols.items():
            object.__setattr__(self, name, arr)
        if self.torque is not None:
            object.__setattr__(self, "torque", _column("torque", self.torque, n))
        rep = np.asarray(self.replicate, dtype=np.int64).ravel()
        if rep.size == 0:
            rep = np.zeros(n, dtype=np.int64)
        elif rep.size != n:
            raise InputError(f"{rep.size} values, expected {n}", field="replicate")
        object.__setattr__(self, "replicate", rep)
        # the value in SI and as a bench states it (−52.35 alone read as a typo of the
        # file's −499.9 rpm; a pump maker's pass)
        shown = {"omega": lambda v: f"{v:g} rad/s ({v * 30.0 / math.pi:.4g} rpm)",
                 "q": lambda v: f"{v:g} m³/s ({v * 6e4:.4g} l/min)",
                 "torque": lambda v: f"{v:g} N·m"}
        for name, what in (("omega", "shaft speed"), ("q", "delivered flow"),
                           ("torque", "shaft torque")):
            reading: FloatArray | None = cols.get(name, self.torque)
            if reading is not None and np.any(reading <= 0):
                row = int(np.flatnonzero(reading <= 0)[0])
                raise MeasurementError(f"data row {row + 1}: {what} must be positive, got "
                                       f"{shown[name](float(reading[row]))}", field=name)
        if np.any((rep < 0) | (rep > MAX_REPLICATE)):
            row = int(np.flatnonzero((rep < 0) | (rep > MAX_REPLICATE))[0])
            raise MeasurementError(f"data row {row + 1}: replicate number {rep[row]} is not "
                                   f"0 to {MAX_REPLICATE}", field="replicate")
        for name, low, high, unit in _PLAUSIBLE:
            arr = cols[name]
            if np.any(bad := (arr < low) | (arr > high)):
                row = int(np.flatnonzero(bad)[0])
                raise MeasurementError(
                    f"data row {row + 1}: {arr[row]:g} {unit} is outside {low:g} to {high:g} "
                    f"{unit}, beyond any instrument of a pump bench", field=name)
        if np.any(below := p_out - cols["p_in"] < 0):
            row = int(np.flatnonzero(below)[0])
            raise MeasurementError(
                f"data row {row + 1}: outlet pressure {p_out[row] / 1e5:.4g} bar below the "
                f"inlet's {cols['p_in'][row] / 1e5:.4g} bar: not pumping", field="p_out")
        rise = float(np.max(p_out - cols["p_in"]))
        if rise < MIN_PRESSURE_RISE:
            # 20-200 written under "[Pa]" was refused for "too few pressure levels" (a pump
            # field engineer's pass)
            raise MeasurementError(
                f"the outlet pressure rises at most {rise:g} Pa above the inlet: a pump bench "
                f"tests from bars to hundreds of bars; are these bar under a [Pa] header? "
                f"(write the unit the column holds, e.g. 'p_out [bar]')", field="p_out")

    def __len__(self) -> int:
        return int(self.p_out.size)

    @property
    def dp(self) -> FloatArray:
        """Pressure rise Δp = p_out − p_in [Pa]."""
        return self.p_out - self.p_in

    def require_torque(self) -> FloatArray:
        """The torque column [N·m]; raises :class:`InputError` (field ``T``) if absent."""
        if self.torque is None:
            raise InputError("this step needs shaft torque; the data have none", field="T")
        return self.torque

    def subset(self, mask: npt.ArrayLike) -> BenchData:
        """The rows selected by a boolean mask or an index array."""
        idx = np.asarray(mask)
        return BenchData(
            p_in=self.p_in[idx], p_out=self.p_out[idx], omega=self.omega[idx],
            theta=self.theta[idx], q=self.q[idx],
            torque=None if self.torque is None else self.torque[idx],
            replicate=self.replicate[idx], simulated=self.simulated,
            provenance=self.provenance,
        )

    @staticmethod
    def concat(parts: list[BenchData]) -> BenchData:
        """Rows of several data sets, in order (torque kept only if all have it)."""
        if not parts:
            raise InputError("nothing to concatenate", field="parts")
        has_t = all(p.torque is not None for p in parts)
        return BenchData(
            p_in=np.concatenate([p.p_in for p in parts]),
            p_out=np.concatenate([p.p_out for p in parts]),
            omega=np.concatenate([p.omega for p in parts]),
            theta=np.concatenate([p.theta for p in parts]),
            q=np.concatenate([p.q for p in parts]),
            torque=np.concatenate([p.require_torque() for p in parts]) if has_t else None,
            replicate=np.concatenate([p.replicate for p in parts]),
            simulated=any(p.simulated for p in parts),
            provenance="; ".join(dict.fromkeys(p.provenance for p in parts if p.provenance)),
        )
