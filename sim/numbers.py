"""What the library takes as a number: a Python or numpy real scalar (a 0-d array too),
never a bool.  One rule for the rig's parameter overrides and for readings (two copies of
it once disagreed: a float32 reading was refused where the simulator took it)."""

from __future__ import annotations

import numpy as np

__all__ = ["real_number"]


def real_number(value: object) -> float | None:
    """``value`` as a float when it is a real number (``int``, ``float``, a numpy integer or
    floating scalar, or a 0-d array of one), else None (a bool, a string such as
    ``"60 um"``, None, an array, a complex number)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, bool | np.bool_) or not isinstance(
            value, int | float | np.integer | np.floating):
        return None
    return float(value)
