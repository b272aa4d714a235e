"""A component's trend as the service answers it (:mod:`app.services.trends`): its points,
slope, threshold, status and time left, and the status as a table shows it."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime

__all__ = ["UNLIKELY", "ComponentTrendOut", "TrendPointOut", "status_text"]


@dataclass(slots=True)  # not frozen: a frozen one costs 5× to build, per point of a trend
class TrendPointOut:
    """One point: diagnosis, time, rig version, estimate and its interval."""

    diagnosis_id: int
    measured_at: datetime
    rig_version: int
    value: float
    low: float | None
    high: float | None
    probability: float | None


@dataclass(frozen=True, slots=True)
class ComponentTrendOut:
    """A component's trend; times in seconds, values in ``unit`` (``None``: not defined).

    ``crossing_at``: when the fitted line reaches the threshold, or, ``"crossed"``, when it
    did.  ``later_diagnoses``: diagnoses of the rig (in the window) after the last point,
    which gave no estimate of this component; from :data:`~app.services.trends.STALE_AFTER` of them the status
    is ``"stale"`` and nothing is forecast.  ``left_out``: points of older rig versions
    whose parameters differ from the latest version's (``left_out_versions``), not in
    ``points``.  ``unexplained``: points of diagnoses whose readings the rig model and its
    fault library did not explain, left out (an inversion through a model the readings
    contradict estimates nothing: a stalled piston read as a 230 µm seal gap).
    ``step_at``/``step_size``: the latest step in the level
    (:func:`diagnostics.trend_fit.latest_step`); the fit and the forecast then use the
    ``points_fitted`` points after it.
    """

    component: str
    quantity: str
    unit: str
    points: list[TrendPointOut]
    slope: float | None
    slope_low: float | None
    slope_high: float | None
    threshold: float
    threshold_source: str
    status: str
    time_left_s: float | None
    time_left_low_s: float | None
    time_left_high_s: float | None
    crossing_at: datetime | None
    message: str
    later_diagnoses: int = 0
    points_total: int = 0
    left_out: int = 0
    left_out_versions: list[int] = field(default_factory=list)
    unexplained: int = 0
    step_at: datetime | None = None
    step_size: float | None = None
    points_fitted: int = 0


#: below this probability of its component, a point is an estimate "if it were this
#: component", and a status that leans on it says so [-]
UNLIKELY = 0.5


def status_text(trend: ComponentTrendOut) -> str:
    """The trend's status as a table shows it: qualified where its last point's diagnosis
    gave the component a probability below :data:`UNLIKELY` ("crossed if it is the worn
    one, p 0.2"): the CLI's summary read a healthy pump "crossed", 0 days left, from
    estimates of diagnoses that named the valve, where the trend's message says so (a CLI
    pass)."""
    last = max(trend.points, key=lambda p: p.measured_at, default=None)
    p = None if last is None else last.probability
    if p is None or p >= UNLIKELY or trend.status not in ("worsening", "crossed"):
        # "not_worsening if it is the worn one" read oddly (a verification pass)
        return trend.status
    return f"{trend.status} if it is the worn one (p {p:.2g})"
