"""Throttle-valve equivalence: calibration tables → equivalent clearances (paper 002 §2.7).

Paper 002 opens throttle valves H (across the piston) and I (valve P → T) by half turns to
mimic worn internal clearances, and calibrates each opening by the clearance that would
let the same bypass flow pass (Tables 2 and 3).  Both leakage laws have the form

.. math:: Q = a\\,c^3 - b\\,c

with ``a = π·D·ΔP/(12·μ·L)`` and ``b = π·D·ẋ/2`` for the piston (paper 002 eq. 36, Couette
sign of :mod:`sim.components.cylinder`) and ``b = 0`` for the spool (eq. 23).  Two ways to
get the clearance column:

* :func:`clearances_from_law` — ``a`` and ``b`` from geometry, viscosity and the pressure
  difference across the leak path (given by the caller: the table's back-pressure is not
  that difference);
* :func:`clearances_calibrated` — the clearance of one row (the closed row: the existing
  clearance) is known; the unknown factor ``a`` is fitted there,
  ``a = (Q_ref + b·c_ref)/c_ref³``, and the other rows follow at equal ΔP.  With ``b = 0``
  this is the cube rule ``c = c_ref·(Q/Q_ref)^(1/3)``, the paper's ``Q ∝ c³``.

Each row's clearance is the physical root of :func:`diagnostics.leakage_laws.leakage_root`.

The Couette sign: paper 002 eq. 36 prints ``+ π·D·c·ẋ/2``; with chamber areas taken to the
bore and the leak counted relative to the piston the drag opposes it (the module docstring of
:mod:`sim.components.cylinder`).  The paper's own Table 2 column follows its printed sign:
calibrated on the closed row, eq. 36 with ``+`` gives 104.8 / 133.0 / 140.4 µm for the ½-1½
turn rows against the table's 103 / (1)(3)2 / 139, with ``−`` 102.5 / 128.3 / 135.1 µm.  So a
piston clearance from these functions (and from diagnosis) is the physical gap, 2-4 % below
the paper's tabulated "equivalent clearance" at 1-2 turns (a papers pass).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from diagnostics.inversion import leakage_root, piston_law_coefficients, spool_law_coefficient
from diagnostics.throttle_limits import (
    MIN_BACK_PRESSURE_PA,
    check_back_pressure,
    check_bypass_flow,
    check_opening,
    check_temperature,
)
from sim.errors import InputError, ParameterError, SimulationError
from sim.numbers import field_number
from sim.rigs import Condition, Rig
from sim.rigs.assembly import require_rig
from sim.steady import steady_cycle

__all__ = [
    "MIN_BACK_PRESSURE_PA",
    "CalibrationRow",
    "CalibrationTable",
    "Component",
    "EquivalenceTable",
    "clearances_calibrated",
    "clearances_from_law",
    "law_inputs",
    "table_from_columns",
]

Component = Literal["cylinder", "valve"]


@dataclass(frozen=True, slots=True)
class CalibrationRow:
    """One throttle opening and the bypass flow it gave.

    Parameters
    ----------
    opening
        Label as in the source (``"closed"``, ``"1/2 turn"``).
    turns
        Throttle opening [turns] (0 = closed).
    bypass_flow
        Equivalent leakage measured at that opening [m³/s], > 0.
    """

    opening: str
    turns: float
    bypass_flow: float


@dataclass(frozen=True, slots=True)
class CalibrationTable:
    """A throttle-valve calibration table.

    Parameters
    ----------
    component
        ``"cylinder"`` (throttle H) or ``"valve"`` (throttle I).
    rows
        The openings, in any order.
    back_pressure
        Back-pressure of the load control valve during the calibration [Pa]: 0 (no load)
        or 0.1 bar to 1000 bar.
    temperature
        Oil temperature during the calibration [°C], if known: within the rig model's
        −30…150 °C.
    source
        Where the table comes from.

    Raises
    ------
    InputError
        A value outside the limits the HTTP service refuses too
        (:mod:`diagnostics.throttle_limits`), naming the field (``rows[1].turns``,
        ``temperature``, ``back_pressure``).
    """

    component: Component
    rows: tuple[CalibrationRow, ...]
    back_pressure: float
    temperature: float | None = None
    source: str = ""

    def __post_init__(self) -> None:
        if self.component not in ("cylinder", "valve"):
            raise InputError(f"unknown component {self.component!r}", field="component")
        if isinstance(self.rows, str) or not hasattr(self.rows, "__iter__"):
            raise InputError("rows are a sequence of CalibrationRow", field="rows")
        # kept as a tuple: a generator was used up by these checks and left no rows, a
        # list made the frozen table unhashable (a verification pass)
        object.__setattr__(self, "rows", tuple(self.rows))
        if not self.rows:
            raise InputError("a calibration table needs at least one row", field="rows")
        for i, row in enumerate(self.rows):
            if not isinstance(row, CalibrationRow):
                raise InputError(f"a row is a CalibrationRow, not a {type(row).__name__}",
                                 field=f"rows[{i}]")
            check_bypass_flow(row.bypass_flow, f"rows[{i}].bypass_flow")
            # 50 turns was accepted where the service refuses beyond 10 (a library pass)
            check_opening(row.turns, f"rows[{i}].turns")
        # NaN or 500 °C and a negative back-pressure too
        check_back_pressure(self.back_pressure)
        if self.temperature is not None:
            check_temperature(self.temperature)

    @property
    def flows(self) -> np.ndarray:
        """Bypass flows of the rows [m³/s]."""
        return np.array([r.bypass_flow for r in self.rows], dtype=np.float64)


@dataclass(frozen=True, slots=True)
class EquivalenceTable:
    """A calibration table with its equivalent-clearance column.

    Attributes
    ----------
    table
        The calibration table.
    clearances
        Equivalent clearance of each row [m], in the order of ``table.rows``.
    a
        Poiseuille factor of the law ``Q = a·c³ − b·c`` [m³/s per m³].
    b
        Couette factor [m³/s per m].
    method
        ``"law"`` or ``"calibrated"`` (then ``reference_row`` names the row).
    reference_row
        Index of the calibration row (``None`` for ``"law"``).
    """

    table: CalibrationTable
    clearances: tuple[float, ...]
    a: float
    b: float
    method: Literal["law", "calibrated"]
    reference_row: int | None = None

    def clearance_for(self, turns: float) -> float:
        """Equivalent clearance [m] at an opening [turns], linear between table rows."""
        t = np.array([r.turns for r in self.table.rows])
        order = np.argsort(t)
        if not (t[order][0] <= turns <= t[order][-1]):
            raise InputError(f"opening {turns} turns is outside the table "
                             f"({t[order][0]}..{t[order][-1]})", field="turns")
        return float(np.interp(turns, t[order], np.asarray(self.clearances)[order]))


def _solve(table: CalibrationTable, a: float, b: float) -> tuple[float, ...]:
    """Rising-branch roots; with ``a > 0`` and every flow > 0 each row has exactly one."""
    return tuple(float(x) for x in leakage_root(a, b, table.flows))


def clearances_from_law(table: CalibrationTable, *, dp: float, mu: float, D: float, L: float,
                        velocity: float = 0.0) -> EquivalenceTable:
    """Equivalent clearances from the physical law and known geometry.

    Parameters
    ----------
    table
        Calibration table.
    dp
        Pressure difference across the leak path [Pa], > 0: P1 − P2 for the cylinder,
        P_P − P_T for the valve, at the calibration condition.
    mu
        Dynamic viscosity at the calibration temperature [Pa·s].
    D, L
        Bore and piston seal length (cylinder) or spool diameter and sealing length
        (valve) [m].
    velocity
        Piston speed of the working phase [m/s] (cylinder only; Couette term).
    """
    for name, value in (("dp", dp), ("mu", mu), ("D", D), ("L", L)):
        # finite too: mu = inf gave all-NaN clearances (a library user's pass)
        if not (math.isfinite(number := field_number(value, name)) and number > 0.0):
            raise InputError(f"{name} must be finite and > 0, not {value!r}", field=name)
    # NaN dropped the Couette term without a word
    velocity = field_number(velocity, "velocity", expected="a speed [m/s]", finite=True)
    if table.component == "valve" and velocity != 0.0:
        raise InputError("the spool law has no Couette term", field="velocity")
    if table.component == "valve":
        a, b = spool_law_coefficient(D, L) * dp / mu, 0.0  # paper 002 eq. 23
    else:
        a_unit, b_unit = piston_law_coefficients(D, L)  # paper 002 eq. 36
        a, b = a_unit * dp / mu, b_unit * velocity
    return EquivalenceTable(table, _solve(table, a, b), a, b, "law")


def clearances_calibrated(table: CalibrationTable, reference_clearance: float, *,
                          reference_row: int = 0, couette: float = 0.0) -> EquivalenceTable:
    """Equivalent clearances calibrated at one row of known clearance.

    Parameters
    ----------
    table
        Calibration table.
    reference_clearance
        Known clearance of ``reference_row`` [m] (the closed row: the existing clearance).
    reference_row
        Index of the reference row in ``table.rows``.
    couette
        Couette factor ``b = π·D·ẋ/2`` [m²/s] of the piston law at the calibration speed
        (0 for the valve, or to use the paper's plain cube rule).
    """
    if not (isinstance(reference_row, int | np.integer) and not isinstance(reference_row, bool)
            and 0 <= reference_row < len(table.rows)):
        raise InputError(f"no row {reference_row!r}", field="reference_row")
    if not (math.isfinite(c0 := field_number(reference_clearance, "reference_clearance"))
            and c0 > 0.0):
        raise InputError("the reference clearance must be > 0", field="reference_clearance")
    # NaN gave all-NaN clearances (a library user's pass)
    couette = field_number(couette, "couette", expected="a Couette factor [m²/s]", finite=True)
    if table.component == "valve" and couette != 0.0:
        raise InputError("the spool law has no Couette term", field="couette")
    q0 = table.rows[reference_row].bypass_flow
    # Q_ref > 0 puts c_ref above √(b/a), on the rising branch: every row has a unique root
    a = (q0 + couette * c0) / c0**3
    return EquivalenceTable(table, _solve(table, a, couette), a, couette, "calibrated",
                            reference_row)


def table_from_columns(component: Component, openings: Sequence[str], turns: Sequence[float],
                       flows: Sequence[float], *, back_pressure: float,
                       temperature: float | None = None, source: str = "") -> CalibrationTable:
    """Build a :class:`CalibrationTable` from parallel columns (e.g. a stored table).

    Parameters
    ----------
    component
        ``"cylinder"`` (throttle H, across the piston) or ``"valve"`` (throttle I, P → T).
    openings, turns, flows
        Per row: the opening as written (``"closed"``, ``"1/2 turn"`` …), the opening
        [turns] and the measured bypass flow [m³/s].
    back_pressure
        Back-pressure of the calibration [Pa] (paper 002: 10 bar ≙ 2.1 kN).
    temperature
        Oil temperature of the calibration [°C], ``None`` where not recorded.
    source
        Where the table comes from.

    Raises
    ------
    InputError
        Columns of unequal lengths (``field="rows"``); a value no number or outside the
        limits of :class:`CalibrationTable` (naming it: ``rows[2].turns``,
        ``temperature``).
    """
    columns = {"openings": openings, "turns": turns, "flows": flows}
    for name, column in columns.items():
        # a list, an array, a pandas column: sized and iterable, neither text nor a mapping
        if isinstance(column, str | bytes | Mapping) or not isinstance(column, Collection):
            raise InputError(f"{name} is a column (a list), not a {type(column).__name__}",
                             field=name)
    if not (len(openings) == len(turns) == len(flows)):
        raise InputError("the columns must have equal lengths", field="rows")
    rows = tuple(CalibrationRow(str(o), field_number(t, f"rows[{i}].turns", finite=True),
                                field_number(q, f"rows[{i}].bypass_flow", finite=True))
                 for i, (o, t, q) in enumerate(zip(openings, turns, flows, strict=True)))
    return CalibrationTable(component, rows, back_pressure, temperature, source)


def law_inputs(rig: Rig, component: Component, back_pressure_pa: float, temperature_c: float
               ) -> tuple[dict[str, float], float]:
    """The leakage law's inputs (:func:`clearances_from_law`'s ``dp`` [Pa], ``mu`` [Pa·s],
    ``D`` [m], ``L`` [m], ``velocity`` [m/s]) at the rig's operating point of a table's
    condition, and the pump's delivery ω·Vp [m³/s].

    The operating point is the nominal rig's working phase on the steady path
    (:func:`sim.steady.steady_cycle`), the load being the back-pressure on the annulus,
    ``F = p_back · A2`` (paper 002 §3: 10 bar ≙ 2.1 kN); the piston's ΔP is P1 − P2 with
    its speed (the Couette term), bore and seal length Lc; the spool's ΔP is
    P_valve_P − PRvt (valve inlet to its T port) with Dv and Ls; μ from the rig's oil at
    the table's temperature.  (It was computed in the service alone, so a Python user of
    :mod:`diagnostics` could not get a row's clearance from a rig: a design pass.)

    Raises
    ------
    InputError
        ``rig`` no compiled rig, a component without a leakage law (``field="component"``),
        a back-pressure or temperature no number or outside the limits of
        :class:`CalibrationTable` (below :data:`MIN_BACK_PRESSURE_PA` but not 0: bar typed as
        Pa), no operating point, or a piston that does not move there (the relief open),
        naming ``back_pressure_pa`` or ``temperature_c``.
    """
    require_rig(rig)
    if component not in ("cylinder", "valve"):  # "pump" read the valve's (a library pass)
        raise InputError(f"no leakage law for component {component!r} (known: cylinder, "
                         "valve)", field="component")
    # "1e6" raised a bare TypeError (a library user's pass)
    back_pressure_pa = check_back_pressure(back_pressure_pa, "back_pressure_pa")
    temperature_c = check_temperature(temperature_c, "temperature_c")
    rig.require_cycle("the equivalent clearance of a throttle table (paper 002 §2.7)")
    values = rig.values()
    condition = Condition(load=back_pressure_pa * values["cylinder.A2"], back_pressure=0.0,
                          oil_temperature=temperature_c)
    try:
        working = steady_cycle(rig, None, condition).working
    except SimulationError as exc:
        raise InputError(f"no operating point of the rig at this condition: {exc.message}",
                         field="back_pressure_pa") from None
    except ParameterError as exc:
        # the condition the table states, named as the table names it (a 180 °C table's
        # 422 named condition.oil_temperature, a field it does not have)
        field = {"condition.oil_temperature": "temperature_c",
                 "condition.force": "back_pressure_pa"}.get(exc.field or "", exc.field)
        raise InputError(exc.message, field=field) from None
    if not working["speed"] > 0.0:
        # a stalled piston (the relief valve open) stored clearances from a leak law at an
        # operating point the calibration cannot have had (a technician)
        raise InputError(
            f"at {back_pressure_pa / 1e5:g} bar (a load of {condition.load / 1e3:.3g} kN on "
            "the annulus) the rig's piston does not move in the working phase (the relief "
            "valve opens first): a throttle table is taken with the piston moving (paper 002 "
            "§2.7)", field="back_pressure_pa")
    delivery = values["pump.speed"] * values["pump.Vp"]
    mu = rig.fluid.dynamic_viscosity(temperature_c)
    if component == "cylinder":
        return ({"dp": working["P1"] - working["P2"], "mu": mu, "D": values["cylinder.bore"],
                 "L": values["cylinder.Lc"], "velocity": working["speed"]}, delivery)
    return ({"dp": working["P_valve_P"] - values["valve.PRvt"], "mu": mu,
             "D": values["valve.Dv"], "L": values["valve.Ls"], "velocity": 0.0}, delivery)
