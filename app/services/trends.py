"""Trends of a rig's components from its diagnosis history (:mod:`diagnostics.trends`).

For each component the history gives a series of estimates — equivalent clearance of the
cylinder (cc) and valve (cv) [m], slip coefficient Cs of the pump [-] — with the 95 %
interval each diagnosis stated (turned into a standard uncertainty, u = width / 3.92).
The slope is Theil-Sen, widened by those uncertainties; the time left to a threshold comes
with the interval the slope's interval implies.

Default thresholds, when the caller gives none: 1.6 × the rig's nominal clearance for
cylinder and valve (laminar leakage × 4.1, the boundary of "severe" in
:func:`diagnostics.ranking.severity`), and 4.1 × the slip coefficient of the healthy pump
at the rig's default oil temperature.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from datetime import UTC, datetime, timedelta

import numpy as np
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.db.models import Diagnosis, DiagnosisEstimate, Measurement, RigVersion
from app.services.common import current_diagnoses
from app.services.diagnosis import UNEXPLAINED
from app.services.history import HistoryPoint, component_history
from app.services.rig_cache import ResolvedRig, RigCache
from app.services.trend_out import UNLIKELY, ComponentTrendOut, TrendPointOut, status_text
from diagnostics.slip import rig_slip_coefficient
from diagnostics.trends import TrendSeries, forecast_threshold
from sim.errors import CircuitError, InputError
from sim.rigs import Rig, validate_rig_document
from sim.units import quantity_text

__all__ = ["COMPONENTS", "ComponentTrendOut", "TrendPointOut", "comparable_versions",
           "component_trends", "default_threshold", "status_text"]

#: Components with a trend → (quantity, unit).
COMPONENTS: dict[str, tuple[str, str]] = {"cylinder": ("cc", "m"), "valve": ("cv", "m"),
                                          "pump": ("Cs", "1")}
#: Clearance multiple of the default threshold: leakage (c/c0)³ = 4.1, "severe" [-].
CLEARANCE_MULTIPLE = 4.1 ** (1.0 / 3.0)
#: Slip multiple of the default pump threshold [-].
SLIP_MULTIPLE = 4.1
_Z95 = 1.959963984540054
#: later diagnoses without an estimate of a component from which its trend is stale [-]
STALE_AFTER = 3
#: shortest span of visits from which a wear rate is forecast [s]: records posted without
#: ``measured_at`` are stamped with the time of their request, and 26 of them posted one
#: by one read "cc reaches 132.8 µm in 0.0637 s" (a reliability engineer's pass)
MIN_SPAN_S = 3600.0
#: largest clearance threshold [m]: the rig documents' plausibility bound of a clearance
MAX_CLEARANCE_THRESHOLD = 2e-3


def default_threshold(rig: Rig, component: str) -> tuple[float, str]:
    """The default threshold of ``component`` on ``rig`` and how it was derived."""
    if component in ("cylinder", "valve"):
        nominal = rig.base["cylinder.cc" if component == "cylinder" else "valve.cv"]
        return (CLEARANCE_MULTIPLE * nominal,
                "default: 1.6 × nominal clearance (leakage ×4.1, 'severe')")
    theta = rig.default_condition().oil_temperature
    healthy = rig_slip_coefficient(rig, theta)
    # what the number is: paper 000's Cs with D per radian, and the temperature it is
    # taken at (the rig's pump leaks alike at every temperature, so Cs = μ(T)·k/(D·Rlp)
    # moves with the oil: a pump field engineer's pass)
    return SLIP_MULTIPLE * healthy, (
        f"default: 4.1 × the healthy pump's Cs at {theta:g} °C (paper 000 eq. 6, D per "
        "radian; each point's Cs is at its record's oil temperature)")


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _points(component: str, history: list[HistoryPoint]) -> list[TrendPointOut]:
    out = []
    for h in history:
        value = h.slip_coefficient if component == "pump" else h.clearance_m
        if value is None or not math.isfinite(value):
            continue
        out.append(TrendPointOut(h.diagnosis_id, h.measured_at, h.rig_version, value,
                                 h.low, h.high, h.probability))
    return out


def _if_blamed(component: str, point: TrendPointOut) -> str:
    """'; if the pump is the worn one: …' when ``point``'s diagnosis gave its component a
    probability below :data:`UNLIKELY` (a pump estimate from a diagnosis that named the
    valve read "pump past the threshold" as a plain fact)."""
    p = point.probability
    if p is None or p >= UNLIKELY:
        return ""
    return (f"; that estimate holds if the {component} is the worn component, and its "
            f"diagnosis ({point.diagnosis_id}) gave it probability {p:.2g}: another "
            "component explains the readings better")


def _trend(component: str, rig_id: int, points: list[TrendPointOut], threshold: float,
           source: str, later: tuple[int, datetime | None, dict[str, int]] = (0, None, {}),
           current: bool = True) -> ComponentTrendOut:
    """The trend of ``points``; ``current``: the window reaches today (not a view ``until``
    an earlier time, where "diagnose the rig again" was said with 43 later diagnoses
    outside it); ``later``: the rig's diagnoses after the last point (how
    many, and the last one's time), :func:`_later`."""
    quantity, unit = COMPONENTS[component]
    uncertainties: tuple[float, ...] | None = None
    if points and all(p.low is not None and p.high is not None for p in points):
        uncertainties = tuple(max((p.high or 0.0) - (p.low or 0.0), 0.0) / (2 * _Z95)
                              for p in points)
    series = TrendSeries(str(rig_id), component, quantity, unit,
                         tuple(p.measured_at.timestamp() for p in points),
                         tuple(p.value for p in points), uncertainties)
    forecast = forecast_threshold(
        series, threshold, direction="increasing",
        when=lambda t: f"around {datetime.fromtimestamp(t, UTC):%Y-%m-%d}")
    fit = forecast.fit
    crossing = None
    if fit is not None and forecast.status == "crossed":  # when the fitted line crossed it
        crossing = (datetime.fromtimestamp(forecast.crossed_at, UTC)
                    if math.isfinite(forecast.crossed_at) else None)
    elif fit is not None and math.isfinite(forecast.time_left):
        try:
            crossing = datetime.fromtimestamp(forecast.now, UTC) + timedelta(
                seconds=forecast.time_left)
        except OverflowError:  # beyond the calendar: time_left_s says how far
            crossing = None
    status: str = forecast.status
    message = forecast.message
    visits = sorted({p.measured_at for p in points})
    if len(visits) >= 2 and fit is not None and (
            visits[-1] - visits[0]).total_seconds() < MIN_SPAN_S:
        status, crossing, fit = "insufficient_data", None, None
        message = (f"the {len(visits)} visits span "
                   f"{(visits[-1] - visits[0]).total_seconds():.3g} s: a wear rate needs "
                   f"visits at least {MIN_SPAN_S / 3600:g} h apart in all (records posted "
                   "without measured_at are stored at the time of their request: give each "
                   "its time of measurement)")
        forecast = replace(forecast, time_left=math.nan, time_left_low=math.nan,
                           time_left_high=math.nan, step=None, n_used=len(points))
    step_at = (datetime.fromtimestamp(forecast.step.time, UTC) if forecast.step is not None
               else None)
    if points and current and crossing is not None and status == "worsening" \
            and crossing < datetime.now(UTC):
        # counted from the last visit: "13.6 days left" read on a page 48 days later (a
        # maintenance planner's pass)
        message += (f"; counted from the last visit ({points[-1].measured_at:%Y-%m-%d}), "
                    f"the forecast date {crossing:%Y-%m-%d} is already past: diagnose the "
                    "rig again")
    if later[0] and points:
        # what they named: "stale" on a healthy pump read like a fault (an engineer's pass)
        said = ", ".join(f"{name} {n}" for name, n in sorted(
            later[2].items(), key=lambda kv: (-kv[1], kv[0])))
        window = (f"since {points[-1].measured_at:%Y-%m-%d}, to {later[1]:%Y-%m-%d}")
        if later[2].get(UNEXPLAINED, 0) == later[0]:
            # their estimates exist but are left out: "no estimate" was untrue (a planner)
            since = (f"the {later[0]} later diagnosis(es) of this rig ({window}) were not "
                     "explained by the rig model (no hypothesis fits their readings: a rig "
                     "that changed, a sensor fault or a wrongly entered record; check them), "
                     "so their estimates are left out")
        else:
            since = (f"no {quantity} estimate in the {later[0]} later diagnosis(es) of this "
                     f"rig ({window}" + (f"; they named {said}" if said else "")
                     + f"): the {component} alone did not fit their readings, could not be "
                     "observed, or the rig model explained none of them")
        if later[0] >= STALE_AFTER:
            status = "stale"
            message = (f"{since}; the trend of the {len(points)} earlier point(s) forecasts "
                       "nothing now")
            forecast = replace(forecast, time_left=math.nan, time_left_low=math.nan,
                               time_left_high=math.nan)
            crossing = None
        else:
            message = f"{message}; {since}"
    if component == "pump" and status in ("worsening", "crossed"):
        # a healthy model pump's Cs rose as the oil cooled and read "worsening, 656 days"
        # with no word of it in the answer (a reliability engineer's pass; docs/diagnosis.md)
        message += ("; the pump's Cs is read at each record's oil temperature, and the rig "
                    "model's pump leak k·p/Rlp makes it rise as the oil cools: before acting, "
                    "compare records taken at one oil temperature")
    if points and status != "crossed" and points[-1].value > threshold:
        last = points[-1]
        message = (f"{message}; the latest estimate, {quantity_text(last.value, unit)} "
                   f"({last.measured_at:%Y-%m-%d}), is past the threshold (one point: the "
                   f"robust trend weighs it as one of many){_if_blamed(component, last)}")
    elif points and status == "crossed":
        last = points[-1]
        if last.value <= threshold:
            # the fitted line past the threshold, the latest visit well below it: said,
            # as the reverse is ("crossed" beside a healthy last diagnosis; a console pass)
            message = (f"{message}; the latest estimate, {quantity_text(last.value, unit)} "
                       f"({last.measured_at:%Y-%m-%d}), is below the threshold (one point: "
                       "the robust trend weighs it as one of many)")
        message += _if_blamed(component, last)
    return ComponentTrendOut(
        component, quantity, unit, points,
        slope=None if fit is None else fit.slope,
        slope_low=None if fit is None else fit.slope_low,
        slope_high=None if fit is None else fit.slope_high,
        threshold=threshold, threshold_source=source, status=status,
        time_left_s=_finite(forecast.time_left), time_left_low_s=_finite(forecast.time_left_low),
        time_left_high_s=_finite(forecast.time_left_high), crossing_at=crossing,
        message=message, later_diagnoses=later[0], step_at=step_at,
        step_size=None if forecast.step is None else forecast.step.size,
        points_fitted=forecast.n_used,
    )


def component_trends(
    session: Session,
    rigs: RigCache,
    rig_id: int,
    *,
    component: str | None = None,
    threshold: float | None = None,
    since: datetime | None = None,
    until: datetime | None = None,
    max_points: int | None = None,
) -> list[ComponentTrendOut]:
    """Trends of rig ``rig_id``: of ``component``, or of every component with history;
    each trend's ``points`` thinned to at most ``max_points`` (:func:`thinned`; the fit
    uses them all, ``points_total`` counts them).

    Raises
    ------
    NotFoundError
        No such rig.
    InputError
        A component that has no trend, a threshold without a component, or a threshold
        that is not positive.
    """
    if component is not None and component not in COMPONENTS:
        # the CLI's --component was passed on unchecked: "Valve" or "relief" (which the
        # history's filter takes) raised a KeyError traceback (a CLI pass)
        raise InputError(f"no trend of {component!r}: the components with a trend are "
                         f"{', '.join(COMPONENTS)}", field="component")
    if threshold is not None and component is None:
        raise InputError("a threshold belongs to one component; name it", field="threshold")
    if threshold is not None and not (math.isfinite(threshold) and threshold > 0):
        raise InputError("the threshold must be finite and > 0", field="threshold")
    if threshold is not None and component in ("cylinder", "valve") \
            and threshold > MAX_CLEARANCE_THRESHOLD:
        # "threshold=130" meant µm: "reaches 130 m in 7.29e+08 days" (a planner's pass)
        meant = (f"{threshold:g} µm is {threshold * 1e-6:g}" if threshold >= 1.0
                 else f"{threshold:g} mm is {threshold * 1e-3:g}")
        raise InputError(f"a clearance threshold is in m: {threshold:g} m is more than "
                         f"{MAX_CLEARANCE_THRESHOLD:g} m, the largest clearance a rig document "
                         f"holds (a unit slip? {meant})", field="threshold")
    if since is not None and until is not None and until < since:  # as /diagnoses answers
        raise InputError("`until` is before `since`", field="until")
    if max_points is not None and max_points < 2:
        raise InputError("max_points must be at least 2 (the first and the latest point)",
                         field="max_points")
    resolved = rigs.get(session, rig_id, rig_field="rig_id")
    try:  # "0 distinct visit(s): a trend needs 3" on a rig that can never have one (an
        resolved.rig.require_cycle("a trend")  # analyst's pass, 500 series stored)
    except CircuitError as exc:
        raise CircuitError(f"{exc.message} It has no diagnosis history to trend: its pump's "
                           "leak per stored cycle and the leak's shifts are estimated from "
                           f"its plateaus by POST /rigs/{rig_id}/pump-leak (hydrodiag "
                           "pump-leak; diagnostics.real.monitor, docs/real-data.md)",
                           field=exc.field) from None
    if component is not None:
        names = [component]
    else:
        present = session.scalars(
            select(DiagnosisEstimate.component).distinct()
            .join(Diagnosis, DiagnosisEstimate.diagnosis_id == Diagnosis.id)
            .join(Measurement, Diagnosis.measurement_id == Measurement.id)
            .where(Measurement.rig_id == rig_id, current_diagnoses())
        ).all()
        names = [c for c in COMPONENTS if c in set(present)]
    histories = {name: component_history(session, rig_id, name, since=since, until=until)
                 for name in names}
    # every version with a current diagnosis: the later diagnoses a trend counts are of
    # versions comparable with the latest (a re-diagnosis cancelled half-way left later
    # diagnoses of the old version, and the trend read "stale … they named cylinder 75")
    diagnosed = set(session.scalars(
        select(RigVersion.version).distinct()
        .join(Diagnosis, Diagnosis.rig_version_id == RigVersion.id)
        .where(RigVersion.rig_id == rig_id, current_diagnoses())))
    comparable = comparable_versions(session, resolved, diagnosed | {
        h.rig_version for hs in histories.values() for h in hs})
    same = sorted(v for v, ok in comparable.items() if ok)
    out = []
    for name, history in histories.items():
        if threshold is not None:
            limit, source = threshold, "given"
        else:
            limit, source = default_threshold(resolved.rig, name)
        estimated = _points(name, history)
        unexplained = {h.diagnosis_id for h in history if h.verdict == UNEXPLAINED}
        every = [p for p in estimated if p.diagnosis_id not in unexplained]
        points = [p for p in every if comparable[p.rig_version]]
        left = sorted({p.rig_version for p in every if not comparable[p.rig_version]})
        later = (_later(session, rig_id, points[-1].measured_at, until, same) if points
                 else (0, None, {}))
        trend = _trend(name, rig_id, points, limit, source, later,
                       current=until is None or until >= datetime.now(UTC))
        if left:
            n_left = len(every) - len(points)
            note = (f"{n_left} point(s) of version(s) {', '.join(map(str, left))} left out: "
                    f"the rig document's parameters changed in version {resolved.version} "
                    "(commissioning, a rebuild), so estimates made against the older "
                    "document are not comparable; diagnose their records again against "
                    f"version {resolved.version}: POST /rigs/{rig_id}/rediagnose "
                    f"(hydrodiag rigs rediagnose {rig_id})")
            trend = replace(trend, message=f"{trend.message}; {note}", left_out=n_left,
                            left_out_versions=left)
        if n_unexplained := len(estimated) - len(every):
            note = (f"{n_unexplained} point(s) of diagnoses the rig model did not explain "
                    "left out (their readings contradict the model the estimate is made "
                    "with)")
            trend = replace(trend, message=f"{trend.message}; {note}",
                            unexplained=n_unexplained)
        out.append(replace(trend, points=thinned(trend.points, max_points),
                           points_total=len(trend.points)))
    return out


def thinned(points: list[TrendPointOut], max_points: int | None) -> list[TrendPointOut]:
    """At most ``max_points`` of ``points``, evenly spaced in order, the first and the
    latest kept (``None``: all).  A rig diagnosed every cycle has tens of thousands: 35k
    points of each component made a 13.7 MB answer (a fleet pass), more than a chart or a
    client needs; the fit is made before, from all of them."""
    if max_points is None or len(points) <= max_points:
        return points
    keep = np.unique(np.round(np.linspace(0, len(points) - 1, max_points)).astype(int))
    return [points[i] for i in keep]


def comparable_versions(session: Session, latest: ResolvedRig, versions: set[int]
                ) -> dict[int, bool]:
    """Whether each of ``versions`` of the rig has the latest version's parameters and
    fluid: a trend joins only estimates made against the same physics (a commissioned
    seal length or a new nominal clearance moves every estimate by a step).  The older
    documents are read and validated, not compiled: compiling them (as the rig cache
    would) took a new model's compilation for a version with other elements and pushed
    the rigs being diagnosed out of the cache."""
    out = {v: True for v in versions if v == latest.version}
    older = sorted(versions - set(out))
    if not older:
        return out
    rows = session.execute(select(RigVersion.version, RigVersion.document).where(
        RigVersion.rig_id == latest.rig_id, RigVersion.version.in_(older))).all()
    for version, document in rows:
        spec = validate_rig_document(document)
        out[version] = (spec.values() == latest.rig.base
                        and spec.fluid_model() == latest.rig.fluid)
    for v in older:
        out.setdefault(v, False)  # a version no longer stored: not comparable
    return out


def _later(session: Session, rig_id: int, after: datetime, until: datetime | None,
           versions: Sequence[int]) -> tuple[int, datetime | None, dict[str, int]]:
    """How many current diagnoses of rig ``rig_id`` with one of ``versions`` (those
    comparable with the latest) were made of records taken after ``after`` (up to
    ``until``), when the last of those records was taken, and what they named (component
    or verdict → count)."""
    where = [Measurement.rig_id == rig_id, Measurement.measured_at > after,
             current_diagnoses(), RigVersion.rig_id == rig_id,
             RigVersion.version.in_(list(versions))]
    if until is not None:
        where.append(Measurement.measured_at <= until)
    named = session.execute(
        select(Diagnosis.component, func.count(), func.max(Measurement.measured_at)).join(
            Measurement, Diagnosis.measurement_id == Measurement.id)
        .join(RigVersion, Diagnosis.rig_version_id == RigVersion.id).where(*where)
        .group_by(Diagnosis.component)).all()
    counts = {str(c or "healthy"): int(n) for c, n, _ in named}
    last = max((t for _, _, t in named if t is not None), default=None)
    return sum(counts.values()), last, counts
