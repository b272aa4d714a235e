"""From a measurement record to the vector of observations a hypothesis must reproduce.

Each observable is a working-phase reading (pressures and meters, as paper 002 read them)
or a phase speed; the velocity ratio enters only when the two speeds are not both known
(it would count them twice).  The uncertainty of an observation combines:

* the measurement's own standard uncertainty ``u`` (stated or from its instrument class);
* a model floor, ``model_rel`` × the predicted value: the bond-graph model is not the rig;
* the effect of the operating condition's uncertainty (oil temperature changes viscosity by
  ≈ 3 %/K and so every leakage; load changes pressures), propagated to first order by
  finite differences on the healthy rig.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.consistency import RigLimits, check_against_rig
from diagnostics.measurement import MeasurementRecord, Quantity
from sim.errors import MeasurementError, ParameterError
from sim.rigs import Condition, Rig

__all__ = [
    "OBSERVABLE_UNITS",
    "RecordObservations",
    "observe",
    "rig_limits",
    "sim_condition",
]

#: observable → SI unit (the names of :class:`~diagnostics.measurement.MeasurementRecord`)
OBSERVABLE_UNITS: dict[str, str] = {
    "pump_pressure": "Pa",
    "p1": "Pa",
    "p2": "Pa",
    "flow_B": "m^3/s",
    "flow_C": "m^3/s",
    "pump_flow": "m^3/s",
    "speed_work": "m/s",
    "speed_return": "m/s",
    "velocity_ratio": "1",
}


@dataclass
class RecordObservations:
    """Observations of one record, ready for the likelihood.

    Attributes
    ----------
    record
        The record.
    condition
        The simulation condition it maps to.
    names
        Observable names, in order.
    values, u
        Observed values and their measurement standard uncertainties [SI].
    """

    record: MeasurementRecord
    condition: Condition
    names: list[str]
    values: npt.NDArray[np.float64]
    u: npt.NDArray[np.float64]


def rig_limits(rig: Rig) -> RigLimits:
    """The limits a record is checked against, from the rig's parameters."""
    b = rig.values()
    return RigLimits(Vp=b["pump.Vp"], speed=b["pump.speed"], A1=b["cylinder.A1"],
                     A2=b["cylinder.A2"], stroke=b["cylinder.stroke"],
                     speed_offset=b.get("speed_offset.d_speed", 0.0))


def sim_condition(record: MeasurementRecord) -> Condition:
    """The simulation condition of a record.

    A stated load force acts on the piston; a back-pressure alone is applied as the load
    valve's back-pressure in the outlet line (where the record's P2 sees it).
    """
    c = record.condition
    speed = c.pump_speed.value if c.pump_speed is not None else None
    if c.load_force is not None:
        return Condition(load=c.load_force.value, oil_temperature=c.oil_temperature.value,
                         pump_speed=speed)
    assert c.back_pressure is not None
    return Condition(load=0.0, back_pressure=c.back_pressure.value,
                     oil_temperature=c.oil_temperature.value, pump_speed=speed)


#: a circuit's condition parameter → the record's name for it (``condition.<name>``)
_RECORD_CONDITION = {"condition.force": "condition.load_force"}


def check_condition(record: MeasurementRecord, rig: Rig) -> None:
    """Refuse a record whose condition is outside the range the rig's circuit is modelled
    for (:meth:`sim.rigs.Rig.check_condition`), naming the record's field
    (``condition.load_force``, not the circuit's ``condition.force``) and the value the
    record states.

    Raises
    ------
    MeasurementError
        A stated oil temperature, load or back-pressure outside the circuit's bounds.
    """
    try:
        rig.check_condition(sim_condition(record))
    except ParameterError as exc:
        field = exc.field or ""
        raise MeasurementError(exc.message.removeprefix(f"{field}: "),
                               field=_RECORD_CONDITION.get(field, field)) from None


def observe(record: MeasurementRecord, rig: Rig, *, check: bool = True,
            limits: RigLimits | None = None) -> RecordObservations:
    """Observation vector of ``record`` on ``rig`` (checked against the rig's limits,
    ``limits`` when the caller has them already, and its circuit's range of conditions)."""
    if check:
        # the condition's range first: a load past it is the error to name, not the
        # pressures that cannot push it (check_against_rig's unit-slip test)
        check_condition(record, rig)
        check_against_rig(record, limits if limits is not None else rig_limits(rig))
    stroke = Quantity(rig.base["cylinder.stroke"])
    items: list[tuple[str, Quantity]] = []
    for name in ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "pump_flow"):
        q = getattr(record, name)
        if q is not None:
            items.append((name, q))
    vw, vr = record.speed("work", stroke), record.speed("return", stroke)
    if vw is not None:
        items.append(("speed_work", vw))
    if vr is not None:
        items.append(("speed_return", vr))
    if vw is None or vr is None:
        ratio = record.ratio()
        if ratio is not None:
            items.append(("velocity_ratio", ratio))
    if not items:
        raise MeasurementError("the record has no quantity a diagnosis can use "
                               "(pressures, flows, speeds, durations or the velocity ratio)",
                               field=None)  # the record as a whole ("record.record" once)
    names = [n for n, _ in items]
    values = np.array([q.value for _, q in items])
    u = np.array([max(q.u, 1e-300) for _, q in items])
    return RecordObservations(record, sim_condition(record), names, values, u)


def condition_sigma(record: MeasurementRecord) -> tuple[float, float, float]:
    """Standard uncertainties of oil temperature [K], load [N or Pa] and, when stated, pump
    speed [rad/s] of a record (0 when not stated: the rig's speed is taken as exact).  The
    speed's was left out, and a pump's Cs intervals held the truth in 86 % of 1,169 noisy
    field visits where 95 % was due (a pump field engineer's pass)."""
    c = record.condition
    u_t = c.oil_temperature.u
    load = c.load_force if c.load_force is not None else c.back_pressure
    u_f = load.u if load is not None else 0.0
    u_s = c.pump_speed.u if c.pump_speed is not None else 0.0
    return (u_t, u_f if math.isfinite(u_f) else 0.0, u_s if math.isfinite(u_s) else 0.0)
