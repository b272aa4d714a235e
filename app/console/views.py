"""What the diagnosis, history and trends pages show, read from the store.

The console's routes and the CLI's reports (:mod:`app.cli_report`) both build their
pages from these functions, so a report shows what the console shows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import ColumnElement, func, select
from sqlalchemy.orm import Session

from app.console.charts import (
    estimate_charts,
    predicted_for,
    probability_chart,
    reading_chart,
    record_index,
    sigma_for,
    trend_chart,
)
from app.db.models import Diagnosis, DiagnosisEstimate, MeasuredSeries, Measurement, Rig
from app.schemas.diagnose import MeasurementIn
from app.services.common import current_diagnoses, get_or_raise
from app.services.measurements import to_record
from app.services.rig_cache import RigCache
from app.services.trends import ComponentTrendOut, component_trends
from diagnostics.plots import Chart
from sim.errors import InputError
from sim.units import quantity_text

__all__ = ["HISTORY_PAGE", "DiagnosisView", "HistoryPage", "TrendView", "diagnosis_view",
           "history_page", "measured_readings", "trend_views"]

#: Diagnoses per history page [-].
HISTORY_PAGE = 50

_READINGS = ("pump_pressure", "p1", "p2", "flow_B", "flow_C", "pump_flow", "speed_work",
             "speed_return", "duration_work", "duration_return", "velocity_ratio")


@dataclass
class DiagnosisView:
    """One stored diagnosis, ready for a page or a report."""

    id: int
    rig_id: int
    rig_name: str
    rig_version: int
    measured_at: datetime
    component: str | None
    probability: float | None
    result: dict[str, Any]
    record: dict[str, Any]
    readings: list[dict[str, Any]]
    probabilities: Chart
    relative: Chart | None
    estimates: list[Chart]
    #: whether the stored series the record was read from (``record.series_id``) is still
    #: stored (a deleted one's id is never given again, so its link would be a 404)
    series_stored: bool = False
    #: the diagnosis that replaced this one (a re-diagnosis against a later rig version)
    superseded_by: int | None = None

    @property
    def charts(self) -> list[Chart]:
        """Every chart of the diagnosis, in page order."""
        return [self.probabilities, *([self.relative] if self.relative else []),
                *self.estimates]


def measured_readings(record: dict[str, Any], rig_name: str) -> dict[str, tuple[float, float]]:
    """Each reading of a stored record with its standard uncertainty u [SI unit].

    The record is read as ``POST /diagnose`` reads it, so a reading without a stated
    uncertainty gets its instrument class's default, as it did in the diagnosis.
    """
    data = MeasurementIn.model_validate(record)
    measured_at = data.measured_at or datetime.fromisoformat(record["measured_at"])
    rec = to_record(data, path="record", rig_name=rig_name, measured_at=measured_at)
    out = {}
    for name in _READINGS:
        q = getattr(rec, name, None)
        if q is not None and math.isfinite(q.value):
            out[name] = (float(q.value), float(q.u))
    return out


def diagnosis_view(session: Session, diagnosis_id: int) -> DiagnosisView:
    """The stored diagnosis ``diagnosis_id`` with its charts.

    Raises
    ------
    NotFoundError
        No such diagnosis.
    """
    row = get_or_raise(session, Diagnosis, diagnosis_id, what="diagnosis", field="diagnosis_id")
    measurement = row.measurement
    rig = session.get(Rig, measurement.rig_id)
    rig_name = rig.name if rig is not None else str(measurement.rig_id)
    result = dict(row.result)
    measured = measured_readings(dict(measurement.record), rig_name)
    best = sorted(result.get("hypotheses", []), key=lambda f: -(f.get("probability") or 0.0))[:3]
    index = record_index(result)
    sigma = sigma_for(result, index)
    readings = []
    for name, (value, u) in measured.items():
        predicted = {f["name"]: predicted_for(f, index).get(name) for f in best}
        readings.append({"name": name, "unit": result.get("observable_units", {}).get(name, ""),
                         "value": value, "u": u, "sigma": sigma.get(name),
                         "predicted": predicted})
    series_id = measurement.record.get("series_id")
    stored = series_id is not None and session.get(MeasuredSeries, series_id) is not None
    return DiagnosisView(row.id, measurement.rig_id, rig_name, row.rig_version.version,
                         measurement.measured_at, row.component, row.probability, result,
                         dict(measurement.record), readings, probability_chart(result),
                         reading_chart(result, measured), estimate_charts(result),
                         series_stored=stored, superseded_by=row.superseded_by)


@dataclass
class HistoryPage:
    """One page of the stored diagnoses, newest first."""

    rows: list[dict[str, Any]]
    total: int
    page: int
    pages: int


#: what a history row shows of an estimate: its quantity and its value in words
_QUANTITY = {"cylinder": "cc", "valve": "cv", "pump": "Cs"}


def _estimates_of(session: Session, rows: list[dict[str, Any]]) -> None:
    """Each row's estimates of the components its top hypothesis blames ("cv 46.1 µm"), in
    ``rows[i]["estimates"]``: a planner read the history page for clearances and found
    only names (a maintenance planner's pass); one query for the page."""
    ids = [r["id"] for r in rows]
    if not ids:
        return
    found: dict[int, dict[str, str]] = {}
    for diagnosis_id, component, clearance, slip in session.execute(
            select(DiagnosisEstimate.diagnosis_id, DiagnosisEstimate.component,
                   DiagnosisEstimate.clearance_m, DiagnosisEstimate.slip_coefficient)
            .where(DiagnosisEstimate.diagnosis_id.in_(ids))):
        value = clearance if clearance is not None else slip
        if value is None:
            continue
        unit = "m" if clearance is not None else "1"
        found.setdefault(diagnosis_id, {})[component] = \
            f"{_QUANTITY.get(component, component)} {quantity_text(value, unit)}"
    for row in rows:
        blamed = str(row["component"] or "").split("+")
        row["estimates"] = ", ".join(found.get(row["id"], {}).get(c, "") for c in blamed
                                     if c in found.get(row["id"], {}))


def history_page(session: Session, *, rig_id: int | None = None,
                 since: datetime | None = None, until: datetime | None = None,
                 page: int = 1) -> HistoryPage:
    """The ``page``-th page (from 1) of diagnoses, filtered by rig and time of measurement.

    Raises
    ------
    InputError
        ``page`` below 1, or ``since`` after ``until``.
    """
    if page < 1:
        raise InputError("the page number must be ≥ 1", field="page")
    if since is not None and until is not None and since > until:
        raise InputError("'since' must not be after 'until'", field="since")
    conditions: list[ColumnElement[bool]] = [current_diagnoses()]
    if rig_id is not None:
        conditions.append(Measurement.rig_id == rig_id)
    if since is not None:
        conditions.append(Measurement.measured_at >= since)
    if until is not None:
        conditions.append(Measurement.measured_at <= until)
    base = select(Diagnosis.id).join(Measurement, Diagnosis.measurement_id == Measurement.id)
    total = session.scalar(select(func.count()).select_from(base.where(*conditions).subquery()))
    # a page past the last is the last ("page 99 of 3", empty, with a link to an empty
    # page 98: a maintenance planner's pass)
    page = min(page, max(1, math.ceil(int(total or 0) / HISTORY_PAGE)))
    statement = (
        select(Diagnosis.id, Measurement.rig_id, Rig.name, Measurement.measured_at,
               Diagnosis.component, Diagnosis.probability)
        .join(Measurement, Diagnosis.measurement_id == Measurement.id)
        .join(Rig, Rig.id == Measurement.rig_id)
        .where(*conditions)
        .order_by(Measurement.measured_at.desc(), Diagnosis.id.desc())
        .limit(HISTORY_PAGE).offset((page - 1) * HISTORY_PAGE)
    )
    rows = [{"id": i, "rig_id": r, "rig": n, "measured_at": t, "component": c,
             "probability": p, "estimates": ""} for i, r, n, t, c, p in session.execute(statement)]
    _estimates_of(session, rows)
    count = int(total or 0)
    return HistoryPage(rows, count, page, max(1, math.ceil(count / HISTORY_PAGE)))


@dataclass
class TrendView:
    """One component's trend with its chart and its time left in words."""

    component: str
    quantity: str
    unit: str
    n_points: int
    slope: float | None
    slope_low: float | None
    slope_high: float | None
    threshold: float
    threshold_source: str
    status: str
    time_left_days: float | None
    time_left_low_days: float | None
    time_left_high_days: float | None
    crossing_at: datetime | None
    message: str
    chart: Chart
    #: the service's trend it shows (the CLI report prints its summary from it)
    trend: ComponentTrendOut | None = None


def _days(seconds: float | None) -> float | None:
    return None if seconds is None else seconds / 86400.0


#: Most points of a trend chart (the fit uses them all): thinned evenly, as the API does.
CHART_POINTS = 2000


def trend_views(session: Session, rigs: RigCache, rig_id: int, *,
                since: datetime | None = None, until: datetime | None = None,
                component: str | None = None, threshold: float | None = None
                ) -> list[TrendView]:
    """Every component trend of rig ``rig_id``, or ``component``'s with ``threshold``
    (:func:`app.services.trends.component_trends`)."""
    out = []
    for t in component_trends(session, rigs, rig_id, since=since, until=until,
                              component=component, threshold=threshold,
                              max_points=CHART_POINTS):
        out.append(TrendView(
            t.component, t.quantity, t.unit, t.points_total, t.slope, t.slope_low,
            t.slope_high, t.threshold, t.threshold_source, t.status, _days(t.time_left_s),
            _days(t.time_left_low_s), _days(t.time_left_high_s), t.crossing_at, t.message,
            trend_chart(t), t))
    return out
