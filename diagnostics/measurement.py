"""Measurement records: what a maintenance engineer measured on a rig, with uncertainties.

A :class:`MeasurementRecord` names its rig and its operating condition and carries any subset
of the quantities of paper 002's test rig (Figure 1, Table 1): pump pressure, chamber
pressures P1/P2, the flow at the valve inlet (meter B) and at the cylinder outlet (meter C),
piston speeds (or phase durations and stroke) and the working/return velocity ratio.  Every
quantity is a :class:`~diagnostics.quantity.Quantity`: an SI value and its *standard*
uncertainty (instrument classes are read as rectangular bounds, GUM §4.3.7; see
:mod:`diagnostics.quantity` for the conventions and the default instrument classes).

Validation (:meth:`MeasurementRecord.__post_init__`) needs nothing but the record; checks
that need the rig (speed limits from the pump) live in :mod:`diagnostics.consistency`.
All failures raise :class:`sim.errors.MeasurementError` with ``field`` set to the dotted
path of the offending field (``"condition.oil_temperature"``, ``"flow_C.u"``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from datetime import datetime
from typing import Literal

from diagnostics.quantity import (
    CONSISTENCY_K,
    DEFAULT_INSTRUMENTS,
    InstrumentClass,
    Quantity,
    agree,
    combine,
    quotient,
)
from diagnostics.reading_checks import (
    MAX_FLOW_READING,
    MAX_GAUGE_PRESSURE,
    MAX_MAGNITUDE,
    MAX_TEMPERATURE_U,
    MIN_GAUGE_PRESSURE,
    MIN_PRESSURE_READING,
    OIL_TEMPERATURE_RANGE,
    as_quantity,
    check_quantity,
    other_units,
    readings_mapping,
)
from sim.errors import MeasurementError
from sim.rigs.assembly import MAX_PUMP_SPEED

__all__ = [
    "CONSISTENCY_K",
    "DEFAULT_INSTRUMENTS",
    "MAX_FLOW_READING",
    "MAX_GAUGE_PRESSURE",
    "MAX_MAGNITUDE",
    "MAX_PUMP_SPEED",
    "MAX_TEMPERATURE_U",
    "MIN_GAUGE_PRESSURE",
    "MIN_PRESSURE_READING",
    "OIL_TEMPERATURE_RANGE",
    "PRESSURE_FIELDS",
    "InstrumentClass",
    "MeasurementRecord",
    "OperatingCondition",
    "Quantity",
    "agree",
]

@dataclass(frozen=True, slots=True)
class OperatingCondition:
    """Operating condition of a record.

    Parameters
    ----------
    oil_temperature
        Oil temperature [°C].
    load_force
        Load on the piston [N] (paper 002: 2.1, 4.2, 6.3 kN).
    back_pressure
        Back-pressure the load control valve holds in the cylinder's outlet line [Pa];
        stated alone it is simulated there (:func:`diagnostics.observations.sim_condition`:
        P2 sees it, the piston's pressure difference is friction only), stated with
        ``load_force`` it must agree with it as F = p·A2 (paper 002's equivalent loads,
        10/20/30 bar ≙ 2.1/4.2/6.3 kN) and the force is simulated; at least one of
        ``load_force`` and ``back_pressure`` must be given.
    pump_speed
        Pump shaft speed [rad/s]; optional (the rig's nominal speed is used where needed).
    """

    oil_temperature: Quantity
    load_force: Quantity | None = None
    back_pressure: Quantity | None = None
    pump_speed: Quantity | None = None

    def __post_init__(self) -> None:
        lo, hi = OIL_TEMPERATURE_RANGE
        check_quantity("condition.oil_temperature", self.oil_temperature, lower=lo,
                        what="oil temperature", unit="°C")
        if self.oil_temperature.value > hi:
            raise MeasurementError(f"oil temperature above {hi:g} °C is not a plausible reading"
                                   + other_units(self.oil_temperature.value),
                                   field="condition.oil_temperature")
        if self.oil_temperature.u > MAX_TEMPERATURE_U:
            # a 1e9 K uncertainty was stepped through the viscosity law and refused as "oil
            # temperature 100040 °C", a value never sent, on a field not in the request
            # (an edge pass)
            raise MeasurementError(
                f"standard uncertainty {self.oil_temperature.u:g} K states nothing of the oil "
                f"temperature (above {MAX_TEMPERATURE_U:g} K, the span of oil temperatures a "
                "mineral-oil circuit runs at); give the thermometer's uncertainty, or leave "
                "it out for its class", field="condition.oil_temperature.u")
        if self.load_force is None and self.back_pressure is None:
            raise MeasurementError("state the load force or the back-pressure",
                                   field="condition.load_force")
        if self.load_force is not None:
            check_quantity("condition.load_force", self.load_force)
        if self.back_pressure is not None:
            check_quantity("condition.back_pressure", self.back_pressure,
                            lower=MIN_GAUGE_PRESSURE, upper=MAX_GAUGE_PRESSURE, unit="Pa",
                            what="gauge pressure")
        if self.pump_speed is not None:  # a pump at rest delivers nothing to diagnose
            check_quantity("condition.pump_speed", self.pump_speed, lower=0.0, strict=True,
                            upper=MAX_PUMP_SPEED, unit="rad/s", what="pump speed")

    @classmethod
    def from_readings(cls, readings: Mapping[str, float | Quantity], *,
                      instruments: Mapping[str, InstrumentClass] = DEFAULT_INSTRUMENTS
                      ) -> OperatingCondition:
        """Build from ``{"oil_temperature": 40.0, "back_pressure": Quantity(...)}``.

        Bare numbers are readings of the default instrument class of
        ``"condition.<name>"``; unknown names, and ``readings`` that are not a mapping (a
        list of pairs: ``dict(pairs)`` first), raise :class:`MeasurementError`
        (``field="condition"``).
        """
        names = {f.name for f in fields(cls)}
        kwargs: dict[str, Quantity] = {}
        for name, item in readings_mapping(readings, "condition").items():
            if name not in names:
                raise MeasurementError("unknown operating-condition field",
                                       field=f"condition.{name}")
            kwargs[name] = as_quantity(f"condition.{name}", item, instruments)
        if "oil_temperature" not in kwargs:
            raise MeasurementError("the oil temperature is required",
                                   field="condition.oil_temperature")
        return cls(**kwargs)


#: the record's gauge pressures [Pa]
PRESSURE_FIELDS = ("pump_pressure", "p1", "p2")
_FLOW_FIELDS = ("flow_B", "flow_C", "pump_flow")
_SPEED_FIELDS = ("speed_work", "speed_return")
_POSITIVE_FIELDS = ("duration_work", "duration_return", "stroke", "velocity_ratio")
_MEASURED = PRESSURE_FIELDS + _FLOW_FIELDS + _SPEED_FIELDS + _POSITIVE_FIELDS


@dataclass(frozen=True, slots=True)
class MeasurementRecord:
    """One visit's measurements on one rig (any subset of the fields).

    Parameters
    ----------
    rig_id
        Identifier of the rig.
    condition
        Operating condition (load / back-pressure, oil temperature, pump speed).
    rig_name
        Human name of the rig.
    taken_at
        When the measurements were taken.
    pump_pressure
        Pump outlet pressure, gauge [Pa].
    p1, p2
        Chamber pressures, gauge [Pa] (chamber 1 is pressurised in the working phase).
    flow_B
        Flow at the directional-valve inlet, paper 002 meter B [m³/s].
    flow_C
        Flow out of the cylinder in the working phase, paper 002 meter C [m³/s].
    pump_flow
        Flow at the pump outlet [m³/s] (paper 000's field flowmeter); for the pump slip
        inversion.  On paper 002's rig it equals ``flow_B`` while the relief valve is shut.
    speed_work, speed_return
        Average piston speed in the working / return phase [m/s], as magnitudes.
    duration_work, duration_return
        Duration of the working / return stroke [s].
    stroke
        Distance travelled in each phase [m] (the full stroke for end-to-end cycles).
    velocity_ratio
        Working-phase over return-phase average speed [-] (paper 002 §3).
    calibration_share
        Share of each stated variance (readings, load, oil temperature, pump speed) that is
        the instrument's calibration error, the same in every record of a joint diagnosis
        the instrument reads [-], 0-1 (:mod:`diagnostics.shared_errors`; 0: independent).
    """

    rig_id: str
    condition: OperatingCondition
    rig_name: str | None = None
    taken_at: datetime | None = None
    pump_pressure: Quantity | None = None
    p1: Quantity | None = None
    p2: Quantity | None = None
    flow_B: Quantity | None = None
    flow_C: Quantity | None = None
    pump_flow: Quantity | None = None
    speed_work: Quantity | None = None
    speed_return: Quantity | None = None
    duration_work: Quantity | None = None
    duration_return: Quantity | None = None
    stroke: Quantity | None = None
    velocity_ratio: Quantity | None = None
    calibration_share: float = 0.0

    def __post_init__(self) -> None:
        if not (isinstance(self.rig_id, str) and self.rig_id.strip()):
            raise MeasurementError("a record must name its rig", field="rig_id")
        share = self.calibration_share
        if isinstance(share, bool) or not isinstance(share, (int, float)) \
                or not 0.0 <= float(share) <= 1.0:    # NaN fails too
            raise MeasurementError(
                f"the share of each stated variance that is an instrument's calibration "
                f"error is a number from 0 to 1, got {share!r}", field="calibration_share")
        object.__setattr__(self, "calibration_share", float(share))
        if not isinstance(self.condition, OperatingCondition):
            raise MeasurementError("expected an OperatingCondition", field="condition")
        for name in PRESSURE_FIELDS:
            self._check(name, lower=MIN_GAUGE_PRESSURE, what="gauge pressure",
                        upper=MAX_GAUGE_PRESSURE, unit="Pa")
        for name in _FLOW_FIELDS:
            self._check(name, lower=0.0, what="flow", unit="m³/s")
        for name in _SPEED_FIELDS:
            self._check(name, lower=0.0, what="speed magnitude", unit="m/s")
        for name in _POSITIVE_FIELDS:
            self._check(name, lower=0.0, strict=True,
                        unit={"stroke": "m", "velocity_ratio": ""}.get(name, "s"))
        self._check_ratio_sources()
        for phase in ("work", "return"):
            self._check_speed_vs_duration(phase)

    def _check(self, name: str, *, lower: float, strict: bool = False, what: str = "value",
               upper: float | None = None, unit: str = "") -> None:
        q = getattr(self, name)
        if q is not None:
            check_quantity(name, q, lower=lower, strict=strict, what=what, upper=upper,
                            unit=unit)

    def _check_speed_vs_duration(self, phase: str) -> None:
        """A stated speed must agree with stroke / duration of the same phase."""
        v: Quantity | None = getattr(self, f"speed_{phase}")
        t: Quantity | None = getattr(self, f"duration_{phase}")
        if v is None or t is None or self.stroke is None:
            return
        derived = quotient(self.stroke, t)
        if not agree(v, derived):
            raise MeasurementError(
                f"speed {v.value:.4g} m/s disagrees with stroke/duration {derived.value:.4g} m/s "
                f"beyond {CONSISTENCY_K:g} standard uncertainties", field=f"speed_{phase}")

    def _check_ratio_sources(self) -> None:
        """The speeds, the durations and the stated ratio must tell the same ratio.

        The later source in that order is blamed (``field``) for a disagreement.
        """
        sources: list[tuple[str, Quantity]] = []
        if self.speed_work is not None and self.speed_return is not None \
                and self.speed_return.value > 0.0:
            sources.append(("speed_return", quotient(self.speed_work, self.speed_return)))
        if self.duration_work is not None and self.duration_return is not None:
            sources.append(("duration_return",
                            quotient(self.duration_return, self.duration_work)))
        if self.velocity_ratio is not None:
            sources.append(("velocity_ratio", self.velocity_ratio))
        for i, (_, first) in enumerate(sources):
            for name, other in sources[i + 1:]:
                if not agree(first, other):
                    raise MeasurementError(
                        f"velocity ratio {other.value:.4g} from {name} disagrees with "
                        f"{first.value:.4g} beyond {CONSISTENCY_K:g} standard uncertainties",
                        field=name)

    @classmethod
    def from_readings(cls, rig_id: str, condition: OperatingCondition,
                      readings: Mapping[str, float | Quantity], *, rig_name: str | None = None,
                      taken_at: datetime | None = None,
                      instruments: Mapping[str, InstrumentClass] = DEFAULT_INSTRUMENTS,
                      calibration_share: float = 0.0) -> MeasurementRecord:
        """Build a record from ``{"flow_C": 4.6e-4, "p1": Quantity(12e5, 2e3), ...}``.

        Bare numbers become readings of the field's instrument class (``instruments``,
        default :data:`DEFAULT_INSTRUMENTS`); unknown names, and ``readings`` that are not a
        mapping (a list of pairs: ``dict(pairs)`` first), raise :class:`MeasurementError`
        (``field="readings"``).
        """
        kwargs: dict[str, Quantity] = {}
        for name, item in readings_mapping(readings, "readings").items():
            if name not in _MEASURED:
                raise MeasurementError("unknown measurement field", field=name)
            kwargs[name] = as_quantity(name, item, instruments)
        return cls(rig_id=rig_id, condition=condition, rig_name=rig_name, taken_at=taken_at,
                   calibration_share=calibration_share, **kwargs)

    def speed(self, phase: Literal["work", "return"], stroke: Quantity | None = None
              ) -> Quantity | None:
        """Average piston speed of a phase [m/s], from every determination available.

        The stated speed and ``stroke/duration`` (with the record's stroke, else the
        ``stroke`` given here, e.g. the rig's) are combined by inverse-variance weighting;
        they were checked for agreement at construction.  ``None`` if neither is available.
        """
        v: Quantity | None = getattr(self, f"speed_{phase}")
        t: Quantity | None = getattr(self, f"duration_{phase}")
        s = self.stroke if self.stroke is not None else stroke
        derived = quotient(s, t) if (s is not None and t is not None) else None
        if v is None:
            return derived
        if derived is None:
            return v
        return combine(v, derived)

    def ratio(self) -> Quantity | None:
        """Working/return velocity ratio [-]: from both speeds, else as stated, else t_r/t_w."""
        vw, vr = self.speed("work"), self.speed("return")
        if vw is not None and vr is not None and vr.value > 0.0:
            return quotient(vw, vr)
        if self.velocity_ratio is not None:
            return self.velocity_ratio
        if self.duration_work is not None and self.duration_return is not None:
            return quotient(self.duration_return, self.duration_work)
        return None
