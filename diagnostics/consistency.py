"""Checks of a measurement record against the limits of its rig.

A record can be impossible on one rig and plausible on another: the pump of paper 002
delivers at most ``Qp = ω·Vp`` (eq. 2), so the piston cannot move faster than
``ω·Vp / A1`` in the working phase (flow into chamber 1) or ``ω·Vp / A2`` in the return
phase (flow into chamber 2).  These limits come from the rig, so they arrive as an explicit
:class:`RigLimits` argument; :func:`check_against_rig` raises
:class:`sim.errors.MeasurementError` when a reading exceeds them by more than
:data:`~diagnostics.measurement.CONSISTENCY_K` standard uncertainties.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from diagnostics.measurement import MeasurementRecord
from diagnostics.quantity import CONSISTENCY_K, Quantity, agree
from sim.errors import MeasurementError, ParameterError

__all__ = ["SLOW_FACTOR", "RigLimits", "check_against_rig", "slow_stroke_notes"]


@dataclass(frozen=True, slots=True)
class RigLimits:
    """What the rig allows a record to contain.

    Parameters
    ----------
    Vp
        Pump geometric displacement [m³/rad] (paper 002 eq. 2).
    speed
        Nominal pump speed ω [rad/s], used when the record states none.
    A1, A2
        Effective piston areas of chambers 1 and 2 [m²].
    stroke
        Cylinder stroke [m]; ``None`` skips the stroke check.
    speed_offset
        The rig's speed-reading offset Δω (true − stated) [rad/s], from its
        ``speed_offset`` effect (:mod:`sim.components.effects.speed_offset`): the pump
        turns at ω + Δω.  A rig version that the discrepancy workflow stored with the
        offset refused the very cycles it was fitted to ("exceeds the pump's theoretical
        maximum"; a modelling engineer's pass).
    """

    Vp: float
    speed: float
    A1: float
    A2: float
    stroke: float | None = None
    speed_offset: float = 0.0

    def __post_init__(self) -> None:
        for name in ("Vp", "speed", "A1", "A2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ParameterError(f"must be finite and > 0, got {value}", field=name)
        if self.stroke is not None and not (math.isfinite(self.stroke) and self.stroke > 0.0):
            raise ParameterError(f"must be finite and > 0, got {self.stroke}", field="stroke")

    def delivery(self, omega: float | None = None) -> float:
        """Geometric pump flow (ω + Δω)·Vp [m³/s] (paper 002 eqs. 1-2; Δω the speed-reading
        offset, paper 000 §5, where it adds) at pump speed ``omega`` [rad/s], else the
        nominal."""
        return ((self.speed if omega is None else omega) + max(self.speed_offset, 0.0)) \
            * self.Vp

    def max_pump_flow(self, record: MeasurementRecord) -> float:
        """:meth:`delivery` at the record's speed (+k·u), else the nominal [m³/s]."""
        w = record.condition.pump_speed
        return self.delivery(None if w is None else w.value + CONSISTENCY_K * w.u)

    def max_piston_speed(self, omega: float | None = None) -> float:
        """Fastest piston speed the pump can drive, :meth:`delivery` over the smaller
        chamber area, min(A1, A2) [m/s] (no accumulator adds flow)."""
        return self.delivery(omega) / min(self.A1, self.A2)


#: fraction of F/A1 below which a pressure cannot hold a stated load [-] (generous: a
#: pressure in bar typed as Pa is 1e-5 of it)
LOAD_FRACTION = 0.2
#: the chambers' net force P1·A1 − P2·A2 at least this many times a stated load, and at
#: least :data:`UNIT_SLIP_FORCE`, reads as a load in kN typed as N [-] (friction alone
#: gives the paper-002 piston ~170 N, so a stated load of a few newtons at rest is not it)
LOAD_MULTIPLE = 500.0
#: least net force [N] for :data:`LOAD_MULTIPLE` to say a unit slip
UNIT_SLIP_FORCE = 1000.0
#: a phase's piston speed below the pump's ω·Vp/A by this factor is noted [-] (and a
#: measured series' crossing, :mod:`diagnostics.time_scale`)
SLOW_FACTOR = 30.0


def _exceeds(q: Quantity, limit: float) -> bool:
    return q.value - CONSISTENCY_K * q.u > limit


def check_against_rig(record: MeasurementRecord, limits: RigLimits) -> None:
    """Raise :class:`MeasurementError` if ``record`` is impossible on the rig ``limits``.

    Checks, each beyond ``CONSISTENCY_K`` standard uncertainties:

    * piston speeds (stated or from stroke/duration) above ``ω·Vp/A1`` (working phase) or
      ``ω·Vp/A2`` (return phase), and a phase's duration below the stroke's time at that
      speed (checked on the duration: the derived speed's uncertainty grows as 1/t²);
    * flows at meter B and at the pump outlet above ``ω·Vp``;
    * meter C above what meter B feeds: in the working phase
      ``Q_C = Q_B − Q_lv − (A1 − A2)·ẋ`` with ``Q_lv ≥ 0`` (paper 002 eqs. 10, 25-26);
    * the record's stroke against the rig's;
    * load force against back-pressure: ``F = p_back·A2`` (paper 002 §2.7: 10 bar ↔ 2.1 kN);
    * the pressures that push a stated load: while the piston moves in the working phase
      ``P1·A1 ≥ F`` (paper 002 eq. 33), and the pump's pressure is above P1's, so
      ``p1`` or ``pump_pressure`` below :data:`LOAD_FRACTION` of ``F/A1`` is a reading in
      the wrong unit (bar typed as Pa: a first-day user pass got a 2,000-character
      "unexplained" instead of this);
    * the other way round, the piston's force balance while it moves (paper 002 eq. 33,
      ``A1·P1 − A2·P2 = F + friction + m·ẍ``): a net chamber force of at least
      :data:`UNIT_SLIP_FORCE` and :data:`LOAD_MULTIPLE` × the stated load is a load in kN
      typed as N.
    """
    q_max = limits.max_pump_flow(record)
    rig_stroke = None if limits.stroke is None else Quantity(limits.stroke)
    phases: tuple[tuple[Literal["work", "return"], float], ...] = (("work", limits.A1),
                                                                  ("return", limits.A2))
    for phase, area in phases:
        t = getattr(record, f"duration_{phase}")
        s = record.stroke if record.stroke is not None else rig_stroke
        if t is not None and s is not None:
            # the stroke's shortest time, on the duration itself: its speed's linear
            # uncertainty s·u_t/t² grows without bound as t nears u_t, so 0.01 s for a
            # 0.5 m stroke (50 m/s) passed the speed check and read as healthy (an edge pass)
            shortest = (s.value - CONSISTENCY_K * s.u) * area / q_max
            if t.value + CONSISTENCY_K * t.u < shortest:
                raise MeasurementError(
                    f"a {phase} stroke of {t.value:.4g} s is shorter than the {shortest:.4g} s "
                    f"the pump's theoretical flow needs to move the piston {s.value:.4g} m "
                    "(ω·Vp/A)", field=f"duration_{phase}")
        v = record.speed(phase, stroke=rig_stroke)
        if v is not None and _exceeds(v, q_max / area):
            stated = getattr(record, f"speed_{phase}") is not None
            raise MeasurementError(
                f"piston speed {v.value:.4g} m/s exceeds the pump's theoretical maximum "
                f"{q_max / area:.4g} m/s (ω·Vp/A)",
                field=f"speed_{phase}" if stated else f"duration_{phase}")
    for name in ("flow_B", "pump_flow"):
        q = getattr(record, name)
        if q is not None and _exceeds(q, q_max):
            # l/min typed as m³/s is refused like this; say so as bar and kN are (a user pass)
            lpm = ("; readings are in m³/s (1 l/min = 1.667e-5 m³/s): are these l/min?"
                   if 100.0 * q_max < q.value <= 3.0 * q_max * 60000.0 else "")
            raise MeasurementError(
                f"flow {q.value:.4g} m³/s exceeds the pump's geometric flow {q_max:.4g} "
                f"m³/s{lpm}", field=name)
    _check_meter_c(record, limits)
    if record.stroke is not None and rig_stroke is not None and not agree(record.stroke,
                                                                          rig_stroke):
        raise MeasurementError(
            f"stroke {record.stroke.value:.4g} m differs from the rig's {rig_stroke.value:.4g} m",
            field="stroke")
    cond = record.condition
    moving = record.speed("work", stroke=rig_stroke)
    if cond.load_force is not None and cond.load_force.value > 0 and moving is not None \
            and moving.value > 0:
        # only while the piston moves the load: held at a low relief setting (a stuck-open
        # relief) the chamber holds less than F/A1, and that is a fault, not a unit
        needed = cond.load_force.value / limits.A1
        for name in ("p1", "pump_pressure"):
            p = getattr(record, name)
            if p is not None and p.value + CONSISTENCY_K * p.u < LOAD_FRACTION * needed:
                raise MeasurementError(
                    f"{name} {p.value:.4g} Pa cannot push the stated load of "
                    f"{cond.load_force.value:.4g} N: that takes about F/A1 = "
                    f"{needed / 1e5:.3g} bar ({needed:.4g} Pa); readings are in Pa (1 bar "
                    "= 1e5 Pa): are these bar?", field=name)
        p1, p2 = record.p1, record.p2
        if p1 is not None:
            # the other way round: a load in kN typed as N (5 for 5000) read "unexplained,
            # p1 by +178.6 σ" (an engineer's pass)
            net = p1.value * limits.A1 - (p2.value * limits.A2 if p2 is not None else 0.0)
            if net >= UNIT_SLIP_FORCE and net >= LOAD_MULTIPLE * cond.load_force.value:
                raise MeasurementError(
                    f"the stated load of {cond.load_force.value:.4g} N is "
                    f"1/{net / cond.load_force.value:.0f} of what the chambers push while "
                    f"the piston moves (P1·A1 − P2·A2 = {net:.4g} N): loads are in N "
                    "(1 kN = 1000 N): is this kN?", field="condition.load_force")
    if cond.load_force is not None and cond.back_pressure is not None:
        implied = Quantity(cond.back_pressure.value * limits.A2, cond.back_pressure.u * limits.A2)
        if not agree(cond.load_force, implied):
            raise MeasurementError(
                f"load {cond.load_force.value:.4g} N contradicts back-pressure × A2 = "
                f"{implied.value:.4g} N: a record states one load two ways, as a force or "
                "as the load valve's back-pressure that makes it (paper 002 §2.7); a force "
                "and a separate back-pressure valve acting together (which /simulate adds) "
                "cannot be stated in a record: state the one that loads the rig",
                field="condition.load_force")


def _check_meter_c(record: MeasurementRecord, limits: RigLimits) -> None:
    """Meter C cannot exceed meter B less the area-difference flow (working phase)."""
    qb, qc = record.flow_B, record.flow_C
    if qb is None or qc is None:
        return
    area_term, u_area = 0.0, 0.0
    if limits.A1 != limits.A2:
        v = record.speed("work")
        if v is None:
            return
        area_term, u_area = (limits.A1 - limits.A2) * v.value, abs(limits.A1 - limits.A2) * v.u
    excess = qc.value - (qb.value - area_term)
    if excess > CONSISTENCY_K * math.sqrt(qb.u**2 + qc.u**2 + u_area**2):
        raise MeasurementError(
            f"meter C ({qc.value:.4g} m³/s) exceeds the flow meter B feeds to the cylinder "
            f"({qb.value - area_term:.4g} m³/s"
            + (f": meter B's {qb.value:.4g} less (A1 − A2)·ẋ = {area_term:.4g} m³/s that "
               "the larger chamber keeps" if area_term else "")
            + "): the valve leakage would be negative",
            field="flow_C")


def slow_stroke_notes(record: MeasurementRecord, limits: RigLimits) -> list[str]:
    """A note for each phase whose piston speed (stated, or stroke/duration) is
    :data:`SLOW_FACTOR` × or more below what the pump drives, ω·Vp/A (paper 002 eq. 2):
    a nearly stalled piston — or a duration in ms typed as s, which a user pass had
    answered "cylinder+valve, p = 1.00, severe" without a word.  Possible physics, so a
    note, not a refusal."""
    notes = []
    rig_stroke = None if limits.stroke is None else Quantity(limits.stroke)
    q_max = limits.max_pump_flow(record)
    phases: tuple[tuple[Literal["work", "return"], float], ...] = (("work", limits.A1),
                                                                  ("return", limits.A2))
    for phase, area in phases:
        v = record.speed(phase, stroke=rig_stroke)
        bound = q_max / area
        if v is None or not 0.0 < v.value * SLOW_FACTOR <= bound:
            continue
        duration = getattr(record, f"duration_{phase}")
        typed = (f" (from the stroke over duration_{phase} = {duration.value:.4g} s: if that "
                 f"was in ms, {duration.value / 1000:.4g} s)" if duration is not None
                 and getattr(record, f"speed_{phase}") is None else "")
        notes.append(
            f"the {'working' if phase == 'work' else 'return'} stroke's piston speed "
            f"{v.value:.3g} m/s{typed} is {bound / v.value:.0f}× below the {bound:.3g} m/s "
            "the pump's delivery drives (ω·Vp/A): a nearly stalled piston, or a reading "
            "in the wrong unit")
    return notes
