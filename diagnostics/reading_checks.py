"""Limits of a reading and the checks every reading of a record passes.

The range checks of :class:`~diagnostics.measurement.MeasurementRecord` and
:class:`~diagnostics.measurement.OperatingCondition` (a finite value and uncertainty within
:data:`MAX_MAGNITUDE`, bounds on the value in its unit, a known distribution), a bare number
read as a reading of its field's default instrument class, and the limits that tell a
reading from a unit mistake (bar under ``[Pa]``, l/min under ``[m^3/s]``, kelvin or °F for
°C).  Every failure is a :class:`sim.errors.MeasurementError` naming the field's dotted
path.  Split from :mod:`diagnostics.measurement` by topic.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from diagnostics.quantity import InstrumentClass, Quantity
from sim.cycle_result import VACUUM_GAUGE
from sim.errors import MeasurementError
from sim.numbers import field_number

__all__ = ["MAX_FLOW_READING", "MAX_GAUGE_PRESSURE", "MAX_MAGNITUDE", "MAX_TEMPERATURE_U",
           "MIN_GAUGE_PRESSURE", "MIN_PRESSURE_READING", "OIL_TEMPERATURE_RANGE",
           "as_quantity", "check_quantity", "other_units", "readings_mapping"]

#: Lowest accepted gauge pressure [Pa]: −1 bar is vacuum; below it a reading is impossible.
MIN_GAUGE_PRESSURE = VACUUM_GAUGE
#: Highest accepted gauge pressure [Pa]: 10 kbar, beyond the range of hydraulic pressure
#: transducers (industrial ones end at 1-7 kbar); above it a reading is taken to be an error.
MAX_GAUGE_PRESSURE = 1.0e9
#: Least pressure [Pa] a reading that must carry pressure reaches (0.1 bar): a cycle's
#: chamber, a pump's delivery, a load valve's setting, a bench table's highest rise.  One
#: that stays below is taken for bar (or another unit) written under a ``[Pa]`` label.
MIN_PRESSURE_READING = 1.0e4
#: Largest flow [m³/s] of any pump of a test rig (60,000 l/min); beyond it a flow reading
#: is taken for another unit written under ``[m^3/s]``.
MAX_FLOW_READING = 1.0
#: Largest magnitude of any value or standard uncertainty [SI]: beyond it the squares the
#: diagnosis weighs readings by overflow; an uncertainty that large states nothing (leave
#: the reading out instead).
MAX_MAGNITUDE = 1.0e100

#: Accepted oil temperature range [°C] of a mineral-oil circuit; outside it the reading is
#: taken to be an error rather than a condition.
OIL_TEMPERATURE_RANGE = (-40.0, 150.0)
#: Largest standard uncertainty of a stated oil temperature [K]: beyond the span of
#: :data:`OIL_TEMPERATURE_RANGE` it says nothing of the temperature.
MAX_TEMPERATURE_U = OIL_TEMPERATURE_RANGE[1] - OIL_TEMPERATURE_RANGE[0]


def as_quantity(path: str, item: object,
                 instruments: Mapping[str, InstrumentClass]) -> Quantity:
    """A bare number becomes a reading of the field's default instrument class."""
    if isinstance(item, Quantity):
        return item
    # numpy's scalars are numbers (a float32 reading was refused where the simulator takes
    # it: a verification pass); a bool is not, nor an int beyond the float range (10**400
    # raised a bare OverflowError: a verification pass)
    number = field_number(item, path, error=MeasurementError,
                          expected="a number [SI] or a Quantity")
    instrument = instruments.get(path)
    if instrument is None:
        raise MeasurementError("no default instrument class: state the uncertainty", field=path)
    return instrument.reading(number)


def readings_mapping(readings: object, field: str) -> Mapping[str, object]:
    """``readings`` when it is a mapping of field names, else a :class:`MeasurementError`
    naming ``field``: a list of pairs raised "'list' object has no attribute 'items'" (a
    library user's pass).  A list of pairs is refused rather than read as a mapping: a
    repeated name in it would have to be dropped or chosen without a word."""
    if not isinstance(readings, Mapping):
        raise MeasurementError(f"readings are a mapping of field name → number or Quantity "
                               f"(e.g. {{'p1': 11.9e5}}; dict(pairs) for a list of pairs), "
                               f"not a {type(readings).__name__}", field=field)
    for name in readings:
        if not isinstance(name, str):
            raise MeasurementError(f"a reading is named by its field (e.g. 'p1'), not "
                                   f"{name!r}", field=field)
    return readings


def check_quantity(path: str, q: Quantity, *, lower: float | None = None,
                    strict: bool = False, what: str = "value", upper: float | None = None,
                    unit: str = "") -> None:
    """Finite value and uncertainty of at most :data:`MAX_MAGNITUDE`, and optional bounds
    on the value (``lower``, strict or not; ``upper`` in ``unit``)."""
    if not isinstance(q, Quantity):
        raise MeasurementError(f"expected a Quantity, got {type(q).__name__}", field=path)
    # Quantity("11.88e5", …) raised "TypeError: must be real number" (a library user's pass)
    field_number(q.value, path, error=MeasurementError, expected=f"a {what} [SI]")
    field_number(q.u, f"{path}.u", error=MeasurementError,
                 expected="a standard uncertainty [SI]")
    if not math.isfinite(q.value):
        raise MeasurementError(f"{what} must be finite, got {q.value}", field=path)
    if abs(q.value) > MAX_MAGNITUDE:
        raise MeasurementError(f"{what} {q.value:g} is not a reading (magnitude above "
                               f"{MAX_MAGNITUDE:g})", field=path)
    if not (math.isfinite(q.u) and q.u >= 0.0):
        raise MeasurementError(f"standard uncertainty must be finite and ≥ 0, got {q.u}",
                               field=f"{path}.u")
    if q.u > MAX_MAGNITUDE:
        raise MeasurementError(f"standard uncertainty {q.u:g} states nothing (above "
                               f"{MAX_MAGNITUDE:g}); leave the reading out instead",
                               field=f"{path}.u")
    if upper is not None and q.value > upper:
        raise MeasurementError(f"{what} {q.value:g} {unit} is above {upper:g} {unit}, "
                               "beyond any instrument of a hydraulic rig", field=path)
    if q.distribution not in ("normal", "rectangular"):
        raise MeasurementError(f"unknown distribution {q.distribution!r}",
                               field=f"{path}.distribution")
    if lower is not None and (q.value <= lower if strict else q.value < lower):
        rel = ">" if strict else "≥"
        u = f" {unit}" if unit else ""  # "must be ≥ -40, got -300" named no °C (a user pass)
        raise MeasurementError(f"{what} must be {rel} {lower:g}{u}, got {q.value:g}{u}",
                               field=path)


def other_units(value: float) -> str:
    """What an oil temperature above the range reads as in kelvin or °F, where that lies
    within :data:`OIL_TEMPERATURE_RANGE` ("" where neither does): the unit mistakes a
    logger makes (313 for 40 °C; 140 for 60 °C)."""
    lo, hi = OIL_TEMPERATURE_RANGE
    reads = [f"{c:.1f} °C if it is in {unit}" for c, unit in
             ((value - 273.15, "K"), ((value - 32.0) / 1.8, "°F")) if lo <= c <= hi]
    return f" ({value:g} reads as {' or '.join(reads)}: send °C)" if reads else ""
