"""What the library takes as a number: a Python or numpy real scalar (a 0-d array too),
never a bool.  One rule for the rig's parameter overrides and for readings (two copies of
it once disagreed: a float32 reading was refused where the simulator took it).

:func:`real_number` says whether a value is one; :func:`field_number` is the entry point of
the library's public functions: the value as a float, or the exception tree's error naming
the argument or field (a string, a list or an integer too large for a float raised a bare
``TypeError``, ``AttributeError`` or ``OverflowError``: a library user's pass).
"""

from __future__ import annotations

import math
import reprlib

import numpy as np

from sim.errors import InputError

__all__ = ["field_number", "real_number"]

#: largest finite float [-], named where an integer is too large to become one
_FLOAT_MAX = float(np.finfo(np.float64).max)


def _as_float(value: object) -> float | None:
    """``value`` as a float when it is a real number, else None; ``OverflowError`` for an
    integer beyond the float range."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, bool | np.bool_) or not isinstance(
            value, int | float | np.integer | np.floating):
        return None
    return float(value)


def real_number(value: object) -> float | None:
    """``value`` as a float when it is a real number (``int``, ``float``, a numpy integer or
    floating scalar, or a 0-d array of one), else None (a bool, a string such as
    ``"60 um"``, None, an array, a complex number, an integer too large for a float)."""
    try:
        return _as_float(value)
    except OverflowError:
        return None


def _shown(value: object) -> str:
    """A short ``repr`` of ``value`` for a message (a list of a million items, too)."""
    try:
        return reprlib.repr(value)
    except ValueError:  # an int beyond the interpreter's digit limit
        return f"an object of type {type(value).__name__}"


def field_number(value: object, field: str, *, error: type[InputError] = InputError,
                 expected: str = "a number", finite: bool = False) -> float:
    """``value`` as a float, or ``error`` naming ``field`` and why.

    Parameters
    ----------
    value
        What the caller gave (:func:`real_number` says what counts as a number).
    field
        The argument or field it was given as (``"sample_rate"``, ``"overrides.valve.cv"``,
        ``"condition.oil_temperature"``).
    error
        The class raised (:class:`~sim.errors.InputError` or a subclass of it:
        ``ParameterError`` for a rig's parameters, ``MeasurementError`` for readings).
    expected
        What the field takes, in words (``"a number in SI units"``), for the message.
    finite
        Refuse NaN and ±inf as well.

    Raises
    ------
    InputError
        ``error``: not a real number (a string, a bool, None, an array), an integer too
        large for a float (beyond ±1.8e308), or, with ``finite``, NaN or infinite.
    """
    try:
        number = _as_float(value)
    except OverflowError:
        digits = int(abs(value).bit_length() * math.log10(2.0)) if isinstance(value, int) else 308
        raise error(f"an integer of about 1e{digits} is too large for a float (at most "
                    f"{_FLOAT_MAX:.2g}); {expected} is expected", field=field) from None
    if number is None:
        raise error(f"{expected} is expected, got {type(value).__name__} {_shown(value)}",
                    field=field)
    if finite and not math.isfinite(number):
        raise error(f"{expected} is expected, a finite one, not {number!r}", field=field)
    return number
