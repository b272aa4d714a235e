"""Throttle-valve equivalence tables of a rig (paper 002, §2.7, Tables 2-3).

Rows arrive in any order and are stored in order of opening.  A row without a clearance
gets one from the :class:`~app.services.clearance.ClearanceEstimator` when the service has
one (marked ``computed``); otherwise it stays empty until a later update.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import cast

from sqlalchemy import delete, func, select
from sqlalchemy.orm import Session, selectinload

from app.db.models import CalibrationPoint, ThrottleCalibration
from app.schemas.calibrations import (
    MAX_CLEARANCE_M,
    CalibrationCreate,
    CalibrationPointIn,
    CalibrationUpdate,
    ClearanceOrigin,
)
from app.services.clearance import ClearanceCurveFit, ClearanceEstimator, TablePoint, check_table
from app.services.common import commit, flush, lock_row, paginate
from app.services.rigs import get_rig, latest_version
from sim.errors import ConflictError, InputError, NotFoundError
from sim.rigs.circuits import DEFAULT_CIRCUIT, get_circuit, require_cycle

__all__ = [
    "create_calibration",
    "curve_of",
    "delete_calibration",
    "get_calibration",
    "is_stale",
    "list_calibrations",
    "update_calibration",
]


def get_calibration(session: Session, rig_id: int, calibration_id: int) -> ThrottleCalibration:
    """Return calibration ``calibration_id`` of rig ``rig_id``."""
    get_rig(session, rig_id)
    calibration = session.get(ThrottleCalibration, calibration_id)
    if calibration is None or calibration.rig_id != rig_id:
        raise NotFoundError(
            f"rig {rig_id} has no calibration {calibration_id}", field="calibration_id"
        )
    return calibration


def list_calibrations(
    session: Session, rig_id: int, *, limit: int, offset: int, throttle: str | None = None
) -> tuple[Sequence[ThrottleCalibration], int]:
    """Return a page of the calibrations of rig ``rig_id`` and their total count."""
    get_rig(session, rig_id)
    statement = (
        select(ThrottleCalibration)
        .where(ThrottleCalibration.rig_id == rig_id)
        .options(selectinload(ThrottleCalibration.points))
    )
    if throttle is not None:
        statement = statement.where(ThrottleCalibration.throttle == throttle)
    return paginate(session, statement.order_by(ThrottleCalibration.id), limit=limit,
                    offset=offset)


def is_stale(calibration: ThrottleCalibration, latest_version: int) -> bool:
    """Whether the table's computed clearances were computed with another rig version than
    ``latest_version`` (or one not known: a table stored before revision 0013 on a rig
    with several versions); a table of given clearances only is never stale."""
    computed = any(p.clearance_origin == "computed" for p in calibration.points)
    return computed and calibration.rig_version != latest_version


def curve_of(calibration: ThrottleCalibration) -> ClearanceCurveFit | None:
    """Return the monotone opening → clearance curve of a stored table, if it has one."""
    return ClearanceCurveFit.of([_table_point(p) for p in calibration.points])


def _table_point(point: CalibrationPoint | CalibrationPointIn) -> TablePoint:
    origin: ClearanceOrigin | None
    if isinstance(point, CalibrationPointIn):
        origin = "given" if point.clearance_m is not None else None
    else:
        origin = cast(ClearanceOrigin | None, point.clearance_origin)  # CHECKed in the store
    return TablePoint(point.opening_turns, point.bypass_flow_m3s, point.clearance_m, origin)


def _estimate(
    session: Session,
    calibration: ThrottleCalibration,
    points: Sequence[TablePoint],
    estimator: ClearanceEstimator,
) -> list[TablePoint]:
    """Return ``points`` with each missing clearance computed by ``estimator``; a row whose
    clearance is given is checked by it too (its condition and flow against the rig), and
    keeps its clearance: a table whose every row gave one skipped every check, and flows in
    l/min, 10 "Pa" of back-pressure, a stalled load, 180 °C and component ``pump`` were
    stored (a technician's pass)."""
    document = latest_version(session, get_rig(session, calibration.rig_id)).document
    filled = list(points)
    for index, point in enumerate(points):
        try:
            clearance = estimator(
                rig_document=document,
                component=calibration.component,
                bypass_flow_m3s=point.bypass_flow_m3s,
                back_pressure_pa=calibration.back_pressure_pa,
                temperature_c=calibration.temperature_c,
            )
        except InputError as exc:
            if exc.field != "bypass_flow_m3s":
                raise
            raise InputError(exc.message, field=f"points[{index}].bypass_flow_m3s") from None
        if point.clearance_m is not None:
            continue
        if not (math.isfinite(clearance) and 0 < clearance < MAX_CLEARANCE_M):
            raise InputError(
                f"the computed clearance {clearance:g} m is not a plausible clearance",
                field=f"points[{index}].clearance_m",
            )
        filled[index] = TablePoint(point.opening_turns, point.bypass_flow_m3s, clearance,
                                   "computed")
    return filled


def _rows(
    session: Session,
    calibration: ThrottleCalibration,
    points: Sequence[TablePoint],
    estimator: ClearanceEstimator | None,
) -> list[CalibrationPoint]:
    """Check ``points``, fill missing clearances, return the rows in order of opening; the
    table's ``rig_version`` becomes the latest version when any clearance is computed."""
    order = check_table(points)
    if estimator is not None:
        points = _estimate(session, calibration, points, estimator)
        check_table(points)
    computed = any(p.clearance_origin == "computed" for p in points)
    calibration.rig_version = (get_rig(session, calibration.rig_id).latest_version
                               if computed else None)
    return [
        CalibrationPoint(
            opening_turns=points[i].opening_turns,
            bypass_flow_m3s=points[i].bypass_flow_m3s,
            clearance_m=points[i].clearance_m,
            clearance_origin=points[i].clearance_origin,
        )
        for i in order
    ]


#: back-pressures [Pa] and oil temperatures [K] closer than these are one condition
SAME_BACK_PRESSURE_PA, SAME_TEMPERATURE_K = 1.0, 0.01


def _check_condition_free(
    session: Session, calibration: ThrottleCalibration, *, exclude_id: int | None = None
) -> None:
    statement = select(ThrottleCalibration.id, ThrottleCalibration.back_pressure_pa,
                       ThrottleCalibration.temperature_c).where(
        ThrottleCalibration.rig_id == calibration.rig_id,
        ThrottleCalibration.throttle == calibration.throttle,
        # within what a condition is read to: 1000000.001 Pa was stored beside 1e6 Pa and
        # both listed as "10 bar, 40 °C" (a technician's pass)
        func.abs(ThrottleCalibration.back_pressure_pa - calibration.back_pressure_pa)
        <= SAME_BACK_PRESSURE_PA,
        func.abs(ThrottleCalibration.temperature_c - calibration.temperature_c)
        <= SAME_TEMPERATURE_K,
    )
    if exclude_id is not None:
        statement = statement.where(ThrottleCalibration.id != exclude_id)
    if (row := session.execute(statement.limit(1)).first()) is not None:
        existing, back_pressure, temperature = row     # the stored table's own condition
        raise ConflictError(
            f"rig {calibration.rig_id} already has a table for throttle "
            f"{calibration.throttle!r} at {back_pressure:g} Pa and {temperature:g} °C "
            f"(calibration {existing}); update that one "
            f"(PATCH /rigs/{calibration.rig_id}/calibrations/{existing}) or delete it first "
            f"(DELETE there; hydrodiag calibrate tables --rig {calibration.rig_id} --table "
            f"{existing} --delete)",
            field="throttle",
        )


def create_calibration(
    session: Session,
    rig_id: int,
    data: CalibrationCreate,
    *,
    estimator: ClearanceEstimator | None = None,
) -> ThrottleCalibration:
    """Store a new equivalence table for rig ``rig_id``.

    Raises
    ------
    NotFoundError
        No such rig.
    InputError
        The rows break a rule of :func:`~app.services.clearance.check_table`.
    CircuitError
        The rig's circuit has no cylinder cycle, hence no throttles across its cylinder
        and valve (paper 002 §2.7).
    ConflictError
        The rig has a table for this throttle at this back-pressure and temperature.
    """
    rig = get_rig(session, rig_id)
    circuit = latest_version(session, rig).document.get("circuit", DEFAULT_CIRCUIT)
    require_cycle(get_circuit(circuit), rig.name, "a throttle equivalence table")
    calibration = ThrottleCalibration(
        rig_id=rig_id,
        throttle=data.throttle,
        component=data.component,
        back_pressure_pa=data.back_pressure_pa,
        temperature_c=data.temperature_c,
        source=data.source,
    )
    with session.no_autoflush:
        # the rows first: an invalid table for a throttle that has one was answered 409
        # "update that one", and the update then failed on the rows (an API client's pass)
        points = _rows(session, calibration, [_table_point(p) for p in data.points], estimator)
        _check_condition_free(session, calibration)
        calibration.points = points
    session.add(calibration)
    commit(session, conflict="a table for this throttle and condition exists", field="throttle")
    return calibration


def update_calibration(
    session: Session,
    rig_id: int,
    calibration_id: int,
    data: CalibrationUpdate,
    *,
    estimator: ClearanceEstimator | None = None,
) -> ThrottleCalibration:
    """Change a table; given ``points`` replace all rows.

    Without ``points``, the stored rows stay; if the component, back-pressure or
    temperature changed, or the rig has a newer version than the one that computed them
    (:func:`is_stale`: an empty update refreshes them), their computed clearances are
    computed again.  A condition changed this way *corrects* what the table is: clearances
    given by the caller stay as given (they are the caller's numbers for the table's real
    condition); a table moved to another condition needs its ``points`` sent again (a
    technician read 57.7 µm given at 40 °C kept beside rows computed at 60 °C).  Missing
    clearances are computed whenever the service has an estimator, so an empty update
    fills in what it can.
    """
    calibration = get_calibration(session, rig_id, calibration_id)
    # one writer of a table at a time, and the table as the writer before left it: a
    # no-op update takes the write lock (SQLite's, or PostgreSQL's row lock) and the rows
    # are read again under it (a condition-only PATCH racing a PATCH of the points wrote
    # back the rows it had read before, 8 of 12 rounds: a verification pass)
    lock_row(session, ThrottleCalibration.temperature_c, calibration.id)
    session.refresh(calibration)
    changes = data.model_dump(exclude_unset=True, exclude={"points"})
    condition = (calibration.component, calibration.back_pressure_pa, calibration.temperature_c)
    with session.no_autoflush:
        for key, value in changes.items():
            setattr(calibration, key, value)
        _check_condition_free(session, calibration, exclude_id=calibration.id)
        if data.points is not None:
            points = [_table_point(p) for p in data.points]
        else:
            points = [_table_point(p) for p in calibration.points]
            recompute = condition != (calibration.component, calibration.back_pressure_pa,
                                      calibration.temperature_c) or is_stale(
                calibration, get_rig(session, rig_id).latest_version)
            if recompute:  # computed clearances belong to the old condition or document
                points = [p if p.clearance_origin != "computed" else
                          TablePoint(p.opening_turns, p.bypass_flow_m3s, None)
                          for p in points]
        try:
            rows = _rows(session, calibration, points, estimator)
        except InputError as exc:
            given = any(p.clearance_origin == "given" for p in points)
            if (data.points is not None or not given or not (exc.field or "").startswith(
                    "points[") or not any(p.clearance_m is None for p in points)):
                raise   # a refusal of its own (a unit slip, a stall): as it is
            # rows the caller did not send: computed again (a new rig version, another
            # condition), they no longer rise beside the given ones (the preloaded paper
            # table after a shorter seal length: a check of the technician's fix)
            raise InputError(
                f"computed again, the table's clearances no longer rise with the opening "
                f"beside its given rows ({exc.message}); the given clearances belong to the "
                "condition or rig document they were measured with: send `points` again "
                "(leave a row's clearance out to compute it)", field="points") from None
    conflict = "a table for this throttle and condition exists"
    flush(session, conflict=conflict, field="throttle")  # the table's own changes
    # every row of the table, not those this session loaded: a PATCH racing another deleted
    # rows the other had replaced already (0 matched) and inserted its own beside the
    # other's, a union of both tables that nobody sent (an SRE pass); the last writer wins
    session.execute(delete(CalibrationPoint).where(
        CalibrationPoint.calibration_id == calibration.id),
        execution_options={"synchronize_session": False})
    session.expire(calibration, ["points"])
    calibration.points.extend(rows)
    commit(session, conflict=conflict, field="throttle")
    return calibration


def delete_calibration(session: Session, rig_id: int, calibration_id: int) -> None:
    """Delete a table with its rows."""
    session.delete(get_calibration(session, rig_id, calibration_id))
    commit(session, conflict=f"calibration {calibration_id} is in use")
