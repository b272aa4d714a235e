"""Mistakes in the units readings are stated in, tested when nothing explains the readings.

Two such mistakes are common in a fleet's data, and each moves readings far beyond their
uncertainties, so that the goodness-of-fit test (:mod:`diagnostics.goodness`) rejects every
hypothesis without saying why:

* **absolute pressures** where gauge pressures are asked (``"absolute_pressure"``):
  transducers or a logger that read absolute put every pressure one atmosphere high — at a
  chamber's 1.2 bar back pressure that is +85 %, hundreds of its σ;
* **an oil temperature in °F** where °C is asked (``"fahrenheit"``: 68 stated for 20 °C;
  only where (T − 32)/1.8 lies within 0-90 °C, the oil temperatures the rig is used at).

When the readings are not explained, each mistake the records can carry is undone and the
same ranking and test run on the corrected records (a ranking of its own: the corrected
ones are other readings at, for a temperature, another condition); a mistake is *named*
when the corrected readings pass the χ² and range tests at the same level, with the most
probable hypothesis on them and its probability.  Nothing is corrected in the answer — it stays "not
explained": a named mistake is the likely cause, not a measured fact — and the statement
says which mistake explains the readings and what to send instead.

The atmosphere subtracted is the standard one, 101 325 Pa (ISO 2533), each pressure
reading's uncertainty combined with the atmosphere's: ±10 kPa read as a bound (weather, and
an altitude up to about 900 m), u = 10 kPa/√3, taken as independent between the readings
(stricter than one offset common to them).  A rig above that altitude has a lower
atmosphere, and a mistake there may go unnamed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace

from diagnostics.condition_interval import check_singles
from diagnostics.evidence_at_fit import evidence_at_fit
from diagnostics.goodness import goodness_of_fit
from diagnostics.goodness_result import UnitMistake
from diagnostics.measurement import PRESSURE_FIELDS, MeasurementRecord
from diagnostics.observations import RigLimits, observe
from diagnostics.quantity import Quantity
from diagnostics.ranking import Method, Ranker
from sim.errors import MeasurementError, SimulationError
from sim.rigs import Rig

__all__ = ["ATMOSPHERE", "ATMOSPHERE_U", "UnitMistake", "unit_mistakes"]

#: standard atmosphere (ISO 2533) [Pa]
ATMOSPHERE = 101_325.0
#: its standard uncertainty at a rig: a ±10 kPa bound read as rectangular [Pa]
ATMOSPHERE_U = 10_000.0 / math.sqrt(3.0)
#: oil temperatures a °F reading is taken for when converted [°C]
_CELSIUS_RANGE = (0.0, 90.0)

def _gauge(record: MeasurementRecord) -> MeasurementRecord | None:
    changes = {}
    for name in PRESSURE_FIELDS:
        q: Quantity | None = getattr(record, name)
        if q is not None:
            changes[name] = Quantity(q.value - ATMOSPHERE, math.hypot(q.u, ATMOSPHERE_U))
    return replace(record, **changes) if changes else None  # type: ignore[arg-type]


def _celsius(record: MeasurementRecord) -> MeasurementRecord | None:
    t = record.condition.oil_temperature
    c = (t.value - 32.0) / 1.8
    if not _CELSIUS_RANGE[0] <= c <= _CELSIUS_RANGE[1]:
        return None
    cond = replace(record.condition, oil_temperature=Quantity(c, t.u / 1.8, t.distribution))
    return replace(record, condition=cond)


def _says(mistake: str, records: Sequence[MeasurementRecord]) -> str:
    if mistake == "absolute_pressure":
        return ("the pressures look absolute where gauge pressures are asked: each "
                f"{ATMOSPHERE:.0f} Pa lower")
    temps = ", ".join(f"{r.condition.oil_temperature.value:g}" for r in records)
    conv = ", ".join(f"{(r.condition.oil_temperature.value - 32.0) / 1.8:.1f}"
                     for r in records)
    return (f"the oil temperature looks stated in °F where °C is asked: {temps} °F is "
            f"{conv} °C")


_FIXES: tuple[tuple[str, Callable[[MeasurementRecord], MeasurementRecord | None]], ...] = (
    ("absolute_pressure", _gauge), ("fahrenheit", _celsius))


def unit_mistakes(rig: Rig, records: Sequence[MeasurementRecord], model_rel: float,
                  method: Method, limits: RigLimits) -> list[UnitMistake]:
    """The mistakes of the module docstring that, undone in ``records``, let a hypothesis
    of ``rig`` explain them by a χ² test (``model_rel``, ``method``: the diagnosis's).
    A mistake is tried where every record can carry it (a pressure to correct; a
    temperature that converts into 0-90 °C)."""
    out = []
    for mistake, fix in _FIXES:
        fixed = [fix(r) for r in records]
        if any(f is None for f in fixed):
            continue
        corrected = [f for f in fixed if f is not None]
        try:
            ranker = Ranker(rig, [observe(r, rig, limits=limits) for r in corrected],
                            model_rel, method)
        except (MeasurementError, SimulationError):  # the corrected records are impossible
            continue
        fits = ranker.rank()
        checks = check_singles(ranker, fits)
        evidence_at_fit(ranker, fits, checks)  # the probabilities a diagnosis states
        gof = goodness_of_fit(ranker, fits, at_fit=checks.chi2,
                              at_fit_sigma=checks.reading_sigma())
        if not (gof.explained and gof.testable):
            continue
        top = fits[0]
        out.append(UnitMistake(
            mistake, top.name, top.probability, gof.chi2, gof.dof, gof.limit,
            f"{_says(mistake, records)}, the readings are explained (χ² = {gof.chi2:.3g} on "
            f"{gof.dof} degrees of freedom, limit {gof.limit:.3g}), most probably "
            f"{top.name} (p = {top.probability:.2f}): "
            + ("send gauge pressures" if mistake == "absolute_pressure" else
               "send the oil temperature in °C") + " and diagnose again"))
    return out
