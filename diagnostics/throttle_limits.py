"""The limits of a throttle calibration table, defined once.

The HTTP schema (:mod:`app.schemas.calibrations`) and the library
(:class:`diagnostics.throttle.CalibrationTable`, :func:`diagnostics.throttle.law_inputs`)
refuse the same values (in Python a table at NaN or 500 °C, 50 turns or a negative
back-pressure was accepted where the service answered 422: a library user's pass):

* the oil temperature within the rig model's range (the cycle circuit's
  ``oil_temperature`` condition, −30…150 °C);
* an opening within the rig model's throttle (``sim.components.throttle``: 0…10 turns; an
  opening in degrees, 0/45/90, was stored and interpolated);
* a back-pressure of 0 (no load) or from :data:`MIN_BACK_PRESSURE_PA` (0.1 bar; 10 "Pa"
  was bar typed as Pa) to :data:`MAX_BACK_PRESSURE_PA`;
* a bypass flow above 0 and below :data:`MAX_BYPASS_FLOW` (1 m³/s; a flow beyond it is in
  another unit).

Each check raises :class:`sim.errors.InputError` naming the field.
"""

from __future__ import annotations

from diagnostics.measurement import MAX_FLOW_READING, MIN_PRESSURE_READING
from sim.components.throttle import PARAMETERS as THROTTLE_PARAMETERS
from sim.errors import InputError
from sim.numbers import field_number
from sim.rigs.circuits import get_circuit

__all__ = ["MAX_BACK_PRESSURE_PA", "MAX_BYPASS_FLOW", "MAX_OPENING_TURNS",
           "MIN_BACK_PRESSURE_PA", "TEMPERATURE_RANGE_C", "check_back_pressure",
           "check_bypass_flow", "check_opening", "check_temperature"]

#: the circuit whose throttles (H across the piston, I from P to T) the tables calibrate
_CIRCUIT = "pump-valve-cylinder"
_temperature = next(p for p in get_circuit(_CIRCUIT).condition if p.name == "oil_temperature")
_opening = next(p for p in THROTTLE_PARAMETERS if p.name == "opening")
assert _temperature.lower is not None and _temperature.upper is not None
assert _opening.upper is not None

#: the rig model's range of oil temperature [°C], both ends included
TEMPERATURE_RANGE_C: tuple[float, float] = (_temperature.lower, _temperature.upper)
#: the rig model's widest throttle opening [turn]
MAX_OPENING_TURNS: float = _opening.upper
#: smallest back-pressure of a table other than 0 [Pa]: 0.1 bar, below what a load control
#: valve is set to; a smaller one is a unit slip (bar typed as Pa)
MIN_BACK_PRESSURE_PA = MIN_PRESSURE_READING
#: largest back-pressure of a table [Pa]: 1000 bar, beyond any load control valve's setting
MAX_BACK_PRESSURE_PA = 1.0e8
#: a bypass flow must stay below this [m³/s] (:data:`diagnostics.measurement.MAX_FLOW_READING`)
MAX_BYPASS_FLOW = MAX_FLOW_READING


def check_temperature(value: object, field: str = "temperature") -> float:
    """The calibration's oil temperature [°C] as a float, within
    :data:`TEMPERATURE_RANGE_C`, else an :class:`InputError` naming ``field``."""
    theta = field_number(value, field, expected="an oil temperature [°C]", finite=True)
    lo, hi = TEMPERATURE_RANGE_C
    if not lo <= theta <= hi:
        raise InputError(f"the oil temperature must be ≥ {lo:g} °C and ≤ {hi:g} °C (the rig "
                         f"model's range), got {theta:g} °C", field=field)
    return theta


def check_back_pressure(value: object, field: str = "back_pressure") -> float:
    """The calibration's back-pressure [Pa] as a float: 0 (no load) or within
    [:data:`MIN_BACK_PRESSURE_PA`, :data:`MAX_BACK_PRESSURE_PA`], else an
    :class:`InputError` naming ``field``."""
    p = field_number(value, field, expected="a back-pressure [Pa]", finite=True)
    if p < 0.0 or p > MAX_BACK_PRESSURE_PA:
        raise InputError(f"a back-pressure is 0 (no load) to {MAX_BACK_PRESSURE_PA:g} Pa "
                         f"({MAX_BACK_PRESSURE_PA / 1e5:g} bar), not {p:g} Pa", field=field)
    if 0.0 < p < MIN_BACK_PRESSURE_PA:
        # 10 "Pa" meant 10 bar: a closed row of 56.7 µm on a 34 µm spool was stored (a
        # check of the technician's fix); 0 stays: a table taken without a load
        raise InputError(
            f"a back-pressure of {p:g} Pa ({p / 1e5:g} bar) is no load a rig applies: it "
            "is in Pa (bar × 100,000); 0 for no load", field=field)
    return p


def check_opening(value: object, field: str) -> float:
    """A throttle opening [turn] as a float in [0, :data:`MAX_OPENING_TURNS`], else an
    :class:`InputError` naming ``field``."""
    turns = field_number(value, field, expected="an opening [turn]", finite=True)
    if not 0.0 <= turns <= MAX_OPENING_TURNS:
        raise InputError(f"an opening is 0 (closed) to {MAX_OPENING_TURNS:g} turns (the rig "
                         f"model's throttle), not {turns:g}: openings are in turns, not "
                         "degrees", field=field)
    return turns


def check_bypass_flow(value: object, field: str) -> float:
    """A bypass flow [m³/s] as a float in (0, :data:`MAX_BYPASS_FLOW`), else an
    :class:`InputError` naming ``field``."""
    q = field_number(value, field, expected="a bypass flow [m³/s]", finite=True)
    if not 0.0 < q < MAX_BYPASS_FLOW:
        raise InputError(f"bypass flow must be finite, > 0 and below {MAX_BYPASS_FLOW:g} m³/s "
                         f"(l/min ÷ 60,000), got {q:g}", field=field)
    return q
