"""Measured quantities: a value, its standard uncertainty, and instrument classes.

Uncertainty conventions
-----------------------
* ``Quantity.u`` is always a **standard uncertainty** (one standard deviation, GUM §2.3.1),
  in the unit of the value.
* An instrument accuracy class such as paper 000's "flowmeter ±1 %" is a *bound* (maximum
  permissible error).  Following GUM §4.3.7 it is read as a rectangular distribution of
  half-width ``a``, whose standard uncertainty is ``a/√3``; the resulting quantity is marked
  ``distribution="rectangular"`` so that a Monte Carlo propagation samples it as such
  (GUM Supplement 1, §6.4.2).  A relative and an absolute bound add linearly.
* A user who states an expanded uncertainty ``U`` with coverage factor ``k`` gives
  ``u = U/k`` (:meth:`Quantity.from_expanded`, normal).

Default instrument classes (:data:`DEFAULT_INSTRUMENTS`) — each with its source:

=====================  ===================  ==============================================
quantity               bound                source
=====================  ===================  ==============================================
flows (B, C, pump)     ±1 % of reading      paper 000 §3.2.1 (field flowmeter)
pressures              ±0.25 % of reading   paper 000 §3.2.1 (field pressure transducer)
piston speed           ±0.5 % of reading    chosen: linear encoder (paper 002 item E)
phase duration         ±0.03 s              chosen: one sample at paper 000's 30 ms rate
stroke                 ±0.5 mm              chosen: drawing tolerance of a 0.5 m stroke
velocity ratio         ±1 % of reading      chosen: two encoder speeds, bounds added
oil temperature        ±1 °C                chosen: tank thermometer (paper 002 item 20)
pump speed             ±1 % of reading      chosen: tachometer / motor-slip estimate
load force             ±1 % of reading      chosen: load cell or back-pressure × area
=====================  ===================  ==============================================

Two determinations of one quantity *agree* (:func:`agree`) when they differ by at most
:data:`CONSISTENCY_K` combined standard uncertainties.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

__all__ = [
    "CONSISTENCY_K",
    "DEFAULT_INSTRUMENTS",
    "Distribution",
    "InstrumentClass",
    "Quantity",
    "agree",
    "combine",
    "quotient",
]

Distribution = Literal["normal", "rectangular"]

#: Coverage factor of every consistency test: two determinations of one quantity contradict
#: each other when they differ by more than ``CONSISTENCY_K`` combined standard
#: uncertainties.  3 refuses about 0.3 % of honest Gaussian records (2 would refuse 5 %).
CONSISTENCY_K = 3.0


@dataclass(frozen=True, slots=True)
class Quantity:
    """A measured value and its standard uncertainty.

    Parameters
    ----------
    value
        Measured value [SI unit of the field].
    u
        Standard uncertainty [same unit], ≥ 0.
    distribution
        Shape assigned to the measurement error for Monte Carlo propagation.
    """

    value: float
    u: float = 0.0
    distribution: Distribution = "normal"

    @classmethod
    def from_bound(cls, value: float, half_width: float) -> Quantity:
        """Value known within ``±half_width`` (a bound): rectangular, ``u = a/√3`` (GUM 4.3.7)."""
        return cls(value, half_width / math.sqrt(3.0), "rectangular")

    @classmethod
    def from_expanded(cls, value: float, U: float, k: float = 2.0) -> Quantity:
        """Value with expanded uncertainty ``U`` at coverage factor ``k``: normal, ``u = U/k``."""
        return cls(value, U / k, "normal")

    @property
    def relative(self) -> float:
        """Relative standard uncertainty u/|value| [-] (inf for a zero value with u > 0)."""
        if self.value == 0.0:
            return 0.0 if self.u == 0.0 else math.inf
        return self.u / abs(self.value)


@dataclass(frozen=True, slots=True)
class InstrumentClass:
    """Accuracy class of an instrument, stated as a bound (maximum permissible error).

    Parameters
    ----------
    name
        What the instrument is.
    relative_bound
        ± fraction of the reading [-].
    absolute_bound
        ± constant part [SI unit of the reading].
    source
        Where the figures come from.
    """

    name: str
    relative_bound: float
    absolute_bound: float = 0.0
    source: str = ""

    def reading(self, value: float) -> Quantity:
        """A reading of this instrument: rectangular with half-width ``rel·|value| + abs``."""
        return Quantity.from_bound(value, self.relative_bound * abs(value) + self.absolute_bound)


_FLOWMETER = InstrumentClass("flowmeter", 0.01, 0.0, "paper 000 §3.2.1: flowmeter ±1 %")
_PRESSURE = InstrumentClass("pressure transducer", 0.0025, 0.0,
                            "paper 000 §3.2.1: pressure transducer ±0.25 %")

#: Default instrument class of each record field (keys are field paths).
DEFAULT_INSTRUMENTS: Mapping[str, InstrumentClass] = {
    "pump_pressure": _PRESSURE,
    "p1": _PRESSURE,
    "p2": _PRESSURE,
    "flow_B": _FLOWMETER,
    "flow_C": _FLOWMETER,
    "pump_flow": _FLOWMETER,
    "speed_work": InstrumentClass("linear encoder", 0.005, 0.0, "chosen: encoder speed ±0.5 %"),
    "speed_return": InstrumentClass("linear encoder", 0.005, 0.0, "chosen: encoder speed ±0.5 %"),
    "duration_work": InstrumentClass("timer", 0.0, 0.03, "chosen: one 30 ms sample (paper 000)"),
    "duration_return": InstrumentClass("timer", 0.0, 0.03, "chosen: one 30 ms sample (paper 000)"),
    "stroke": InstrumentClass("stroke", 0.0, 5e-4, "chosen: ±0.5 mm drawing tolerance"),
    "velocity_ratio": InstrumentClass("velocity ratio", 0.01, 0.0,
                                      "chosen: two ±0.5 % encoder speeds, bounds added"),
    "condition.oil_temperature": InstrumentClass("thermometer", 0.0, 1.0,
                                                 "chosen: ±1 °C tank thermometer"),
    "condition.pump_speed": InstrumentClass("tachometer", 0.01, 0.0, "chosen: ±1 % of reading"),
    "condition.load_force": InstrumentClass("load", 0.01, 0.0, "chosen: ±1 % of reading"),
    "condition.back_pressure": _PRESSURE,
}


def agree(a: Quantity, b: Quantity, k: float = CONSISTENCY_K) -> bool:
    """Whether two independent determinations agree: ``|a − b| ≤ k·√(u_a² + u_b²)``."""
    return abs(a.value - b.value) <= k * math.hypot(a.u, b.u)


def quotient(a: Quantity, b: Quantity) -> Quantity:
    """a/b with first-order uncertainty (independent inputs, GUM eq. 12).

    The second term is written ``(a/b)·(u_b/b)`` rather than ``a·u_b/b²``: a divisor near
    the smallest float (a reading of 1e-279) squares to zero.
    """
    value = a.value / b.value
    return Quantity(value, math.hypot(a.u / b.value, value * (b.u / b.value)))


def combine(a: Quantity, b: Quantity) -> Quantity:
    """Inverse-variance weighted mean of two independent determinations."""
    if a.u == 0.0:
        return a
    if b.u == 0.0:
        return b
    wa, wb = 1.0 / a.u**2, 1.0 / b.u**2
    return Quantity((wa * a.value + wb * b.value) / (wa + wb), 1.0 / math.sqrt(wa + wb))
