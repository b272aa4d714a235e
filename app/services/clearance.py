"""Equivalent clearance from a throttle equivalence table: the hook and the curve.

Two pieces:

* :class:`ClearanceEstimator` — the hook through which a table row without a clearance
  gets one computed from its bypass flow.  ``diagnostics`` provides the implementation
  (inversion of the leakage laws of paper 002: eq. 36 for the piston, eq. 23 for the
  spool); the service receives it in :func:`app.main.create_app` and leaves the clearance
  empty while there is none.
* :class:`ClearanceCurveFit` — a monotone interpolant opening → clearance through the
  rows whose clearance is known: PCHIP (Fritsch & Carlson, 1980), which keeps the
  monotonicity of the data and never overshoots between rows.  No extrapolation.

References
----------
F. N. Fritsch and R. E. Carlson, "Monotone piecewise cubic interpolation",
SIAM J. Numer. Anal. 17(2), 238-246, 1980.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Any, Protocol

import numpy as np

from app.schemas.calibrations import ClearanceOrigin
from sim.errors import InputError

__all__ = ["ClearanceCurveFit", "ClearanceEstimator", "TablePoint", "check_table"]


class ClearanceEstimator(Protocol):
    """Computes the equivalent clearance that explains a measured bypass flow.

    Parameters
    ----------
    rig_document
        The rig description (latest version) with the component's geometry and the oil.
    component
        The component the throttle bypasses (``"cylinder"``, ``"valve"``).
    bypass_flow_m3s
        Measured bypass flow [m³/s].
    back_pressure_pa
        Back-pressure of the calibration [Pa].
    temperature_c
        Oil temperature of the calibration [°C].

    Returns
    -------
    float
        Equivalent clearance [m].  Raise an :class:`sim.errors.InputError` subclass when
        the inputs admit none.
    """

    def __call__(
        self,
        *,
        rig_document: Mapping[str, Any],
        component: str,
        bypass_flow_m3s: float,
        back_pressure_pa: float,
        temperature_c: float,
    ) -> float: ...


@dataclass(frozen=True, slots=True)
class TablePoint:
    """One row of an equivalence table: opening [turn], flow [m³/s], clearance [m].

    ``clearance_origin`` says where a known clearance came from: ``"given"`` by the caller
    or ``"computed"`` by a :class:`ClearanceEstimator`.
    """

    opening_turns: float
    bypass_flow_m3s: float
    clearance_m: float | None
    clearance_origin: ClearanceOrigin | None = None


def check_table(points: Sequence[TablePoint], *, field: str = "points") -> list[int]:
    """Check that a table is usable and return the row order by opening.

    Openings must be distinct; as the opening grows, neither the bypass flow nor the known
    clearances may fall (a throttle that opens further passes more oil).

    Parameters
    ----------
    points
        Rows in the caller's order.
    field
        Name of the list in the request, for error paths.

    Returns
    -------
    list of int
        Indices of ``points`` sorted by opening.

    Raises
    ------
    InputError
        A rule is broken; ``field`` names the row (its index as the caller gave it).
    """
    order = sorted(range(len(points)), key=lambda i: points[i].opening_turns)
    for previous, current in pairwise(order):
        a, b = points[previous], points[current]
        if b.opening_turns == a.opening_turns:
            raise InputError(
                f"opening {b.opening_turns} turn appears twice (rows {previous} and {current})",
                field=f"{field}[{current}].opening_turns",
            )
        if b.bypass_flow_m3s < a.bypass_flow_m3s:
            raise InputError(
                f"bypass flow falls from {a.bypass_flow_m3s:g} to {b.bypass_flow_m3s:g} m³/s "
                f"as the opening grows from {a.opening_turns:g} to {b.opening_turns:g} turn",
                field=f"{field}[{current}].bypass_flow_m3s",
            )
    last: tuple[float, float] | None = None  # (opening, clearance) of the last known row
    for index in order:
        point = points[index]
        if point.clearance_m is None:
            continue
        if last is not None and point.clearance_m < last[1]:
            raise InputError(
                f"clearance falls from {last[1]:g} to {point.clearance_m:g} m as the opening "
                f"grows from {last[0]:g} to {point.opening_turns:g} turn",
                field=f"{field}[{index}].clearance_m",
            )
        last = (point.opening_turns, point.clearance_m)
    return order


class ClearanceCurveFit:
    """Monotone curve opening [turn] → clearance [m] through the known rows of a table.

    Parameters
    ----------
    points
        Rows of a table that passed :func:`check_table`, in any order.

    Raises
    ------
    InputError
        Fewer than two rows have a clearance.
    """

    method = "pchip"

    def __init__(self, points: Sequence[TablePoint]) -> None:
        known = sorted(
            (p.opening_turns, p.clearance_m) for p in points if p.clearance_m is not None
        )
        if len(known) < 2:
            raise InputError("the curve needs at least two rows with a clearance",
                             field="points")
        self.opening_turns = [x for x, _ in known]
        self.clearance_m = [y for _, y in known]
        from scipy.interpolate import PchipInterpolator  # heavy; only when a curve is used

        self._interpolant = PchipInterpolator(
            np.asarray(self.opening_turns), np.asarray(self.clearance_m), extrapolate=False
        )

    @classmethod
    def of(cls, points: Sequence[TablePoint]) -> ClearanceCurveFit | None:
        """Return the curve, or ``None`` when fewer than two clearances are known."""
        if sum(p.clearance_m is not None for p in points) < 2:
            return None
        return cls(points)

    def __call__(self, openings_turns: Sequence[float], *, field: str = "opening_turns"
                 ) -> list[float]:
        """Interpolate the clearance [m] at each opening [turn].

        Raises
        ------
        InputError
            An opening lies outside the rows with a known clearance.
        """
        low, high = self.opening_turns[0], self.opening_turns[-1]
        for index, opening in enumerate(openings_turns):
            if not low <= opening <= high:
                raise InputError(
                    f"opening {opening:g} turn is outside the calibrated range "
                    f"[{low:g}, {high:g}] turn",
                    field=f"{field}[{index}]",
                )
        values = self._interpolant(np.asarray(openings_turns, dtype=float))
        return [float(v) for v in values]
