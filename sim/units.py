"""Units accepted in rig files and condition records, and their conversion to SI.

Inside hydrodiag every quantity is SI.  A rig file may state a parameter in any unit of
the same dimension listed here; :func:`to_si` converts it and refuses a unit of another
dimension with a clear message.  The table is deliberately small: it covers the units a
fluid-power engineer writes on a data sheet (bar, L/min, rpm, cm³/rev, µm, cSt, °C).
"""

from __future__ import annotations

import math

from sim.errors import ParameterError

__all__ = ["UNITS", "from_si", "quantity_text", "spelled", "to_si", "unit_suffix"]

_RPM = 2.0 * math.pi / 60.0

#: canonical SI unit -> {accepted spelling: factor to the canonical unit}
UNITS: dict[str, dict[str, float]] = {
    "1": {"1": 1.0, "-": 1.0, "%": 0.01},
    "m": {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "cm": 1e-2},
    "m^2": {"m^2": 1.0, "mm^2": 1e-6, "cm^2": 1e-4},
    "m^3": {"m^3": 1.0, "L": 1e-3, "l": 1e-3, "cm^3": 1e-6, "mm^3": 1e-9},
    "s": {"s": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0},
    "Pa": {"Pa": 1.0, "kPa": 1e3, "bar": 1e5, "MPa": 1e6},
    "m^3/s": {"m^3/s": 1.0, "L/min": 1e-3 / 60.0, "l/min": 1e-3 / 60.0, "cm^3/s": 1e-6},
    "m^3/rad": {"m^3/rad": 1.0, "m^3/rev": 1.0 / (2 * math.pi), "cm^3/rev": 1e-6 / (2 * math.pi),
                "cm³/rev": 1e-6 / (2 * math.pi), "cm3/rev": 1e-6 / (2 * math.pi)},
    "rad/s": {"rad/s": 1.0, "rpm": _RPM, "rev/s": 2.0 * math.pi, "Hz": 2.0 * math.pi},
    # per unit of shaft speed (the pump-filling loss's share of the displacement per rad/s)
    "s/rad": {"s/rad": 1.0, "1/rpm": 1.0 / _RPM},
    "m/s": {"m/s": 1.0, "mm/s": 1e-3},
    "N": {"N": 1.0, "kN": 1e3},
    "kg": {"kg": 1.0, "g": 1e-3},
    "N*s/m": {"N*s/m": 1.0, "N s/m": 1.0},
    "Pa*s": {"Pa*s": 1.0, "Pa s": 1.0, "cP": 1e-3, "mPa*s": 1e-3},
    "m^2/s": {"m^2/s": 1.0, "cSt": 1e-6, "mm^2/s": 1e-6},
    "kg/m^3": {"kg/m^3": 1.0},
    "Pa*s/m^3": {"Pa*s/m^3": 1.0, "bar*min/L": 1e5 * 60.0 / 1e-3},
    "m^3/(s*Pa)": {"m^3/(s*Pa)": 1.0},
    "Pa*s^2/m^6": {"Pa*s^2/m^6": 1.0, "bar/(L/min)^2": 1e5 / (1e-3 / 60.0) ** 2},
    "m^3/Pa": {"m^3/Pa": 1.0, "m^5/N": 1.0},
    "m^3/(s*Pa^0.5)": {"m^3/(s*Pa^0.5)": 1.0},
    "1/K": {"1/K": 1.0},
    "1/Pa": {"1/Pa": 1.0, "1/bar": 1e-5, "1/MPa": 1e-6},
    "degC": {"degC": 1.0, "°C": 1.0, "C": 1.0},
    "N/m": {"N/m": 1.0, "N/mm": 1e3},
    "m/s^2": {"m/s^2": 1.0},
    "W": {"W": 1.0, "kW": 1e3},
    "N*m": {"N*m": 1.0, "N m": 1.0, "Nm": 1.0, "N·m": 1.0, "kN*m": 1e3},
}


def spelled(unit: str) -> str:
    """``unit`` as the tables spell it: stripped, the Greek small mu (U+03BC, what a Greek
    keyboard or a word processor's autocorrect writes) as the micro sign (U+00B5).  "30 μm"
    was refused with a list holding a "µm" that looks the same (a rig author's pass)."""
    return unit.strip().replace("\u03bc", "\u00b5")


def to_si(value: float, unit: str, expected: str, *, field: str | None = None) -> float:
    """Convert ``value`` given in ``unit`` to the canonical SI unit ``expected``.

    Parameters
    ----------
    value
        Number in the stated unit.
    unit
        The unit as written (``"bar"``, ``"L/min"``, ``"µm"`` ...).
    expected
        Canonical unit of the quantity (a key of :data:`UNITS`).
    field
        Name of the field, for the error message.

    Returns
    -------
    float
        The value in ``expected`` [SI].

    Raises
    ------
    ParameterError
        If ``unit`` is not a spelling of a unit of the same dimension as ``expected``.
    """
    table = UNITS.get(expected)
    if table is None:
        raise ParameterError(f"unknown canonical unit {expected!r}", field=field)
    factor = table.get(spelled(unit))
    if factor is None:
        accepted = ", ".join(sorted(table))
        raise ParameterError(
            f"unit {unit!r} is not a unit of this quantity (expected {expected}; accepted: {accepted})",
            field=field,
        )
    return float(value) * factor


def from_si(value: float, unit: str, canonical: str) -> float:
    """Convert an SI ``value`` of canonical unit ``canonical`` into ``unit``."""
    return float(value) / UNITS[canonical][unit]


def unit_suffix(unit: str) -> str:
    """What follows a number: `` Pa`` for a unit, nothing for a dimensionless one (``1``,
    ``-``: "≤ 0.2 1" and "1.1e-07 1" read as typos)."""
    return "" if unit in ("1", "-", "") else f" {unit}"


def quantity_text(value: float, unit: str, digits: int = 4) -> str:
    """A value as an engineer reads it in a sentence: a length below a centimetre in µm
    (a clearance "5.442e-05 m" read as a typo of a planner's 54.42 µm), a rate of length
    per day likewise (zero too: "slope 0 m/day" beside a column in µm/day, a plant
    operator's pass); else ``value`` with ``digits`` significant digits and its unit."""
    if unit in ("m", "m/day") and abs(value) < 1e-2:
        return f"{value * 1e6:.{digits}g} µ{unit}"
    return f"{value:.{digits}g}{unit_suffix(unit)}"
