"""Throttle-valve equivalence tables of a rig, and clearances read off their curves."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Query, Response, status

from app.api.deps import (
    AdminKeyDep,
    EstimatorDep,
    PageDep,
    ReadAccess,
    SessionDep,
    WriteKeyDep,
)
from app.api.routes.rigs import RigId
from app.db.models import ThrottleCalibration
from app.schemas.calibrations import (
    CalibrationCreate,
    CalibrationList,
    CalibrationPointPublic,
    CalibrationPublic,
    CalibrationUpdate,
    ClearanceAt,
    ClearanceCurve,
    ClearanceSamples,
)
from app.schemas.common import ERROR_RESPONSES, MAX_ID, FiniteFloat
from app.services import calibrations as service
from app.services.rigs import get_rig
from sim.errors import InputError

__all__ = ["router"]

router = APIRouter(prefix="/rigs/{rig_id}/calibrations", tags=["calibrations"],
                   dependencies=[ReadAccess], responses=ERROR_RESPONSES)

CalibrationId = Annotated[int, Path(ge=1, le=MAX_ID,
                                    description="Calibration identifier [-]",
                                    examples=[1])]


def _public(calibration: ThrottleCalibration, latest_version: int) -> CalibrationPublic:
    curve = service.curve_of(calibration)
    return CalibrationPublic(
        id=calibration.id,
        rig_id=calibration.rig_id,
        rig_version=calibration.rig_version,
        stale=service.is_stale(calibration, latest_version),
        throttle=calibration.throttle,
        component=calibration.component,
        back_pressure_pa=calibration.back_pressure_pa,
        temperature_c=calibration.temperature_c,
        source=calibration.source,
        points=[CalibrationPointPublic.model_validate(p) for p in calibration.points],
        curve=None if curve is None else ClearanceCurve(
            method="pchip", opening_turns=curve.opening_turns, clearance_m=curve.clearance_m
        ),
        created_at=calibration.created_at,
        updated_at=calibration.updated_at,
    )


@router.get("", summary="List a rig's throttle equivalence tables")
def list_calibrations(
    rig_id: RigId,
    session: SessionDep,
    page: PageDep,
    throttle: Annotated[str | None, Query(max_length=16, description="Only this throttle [-]",
                                          examples=["I"])] = None,
) -> CalibrationList:
    """Return a page of the rig's tables, in order of creation."""
    rows, total = service.list_calibrations(session, rig_id, limit=page.limit,
                                            offset=page.offset, throttle=throttle)
    latest = get_rig(session, rig_id).latest_version
    return CalibrationList(items=[_public(c, latest) for c in rows], total=total,
                           limit=page.limit, offset=page.offset)


@router.post("", status_code=status.HTTP_201_CREATED,
             summary="Store a throttle equivalence table")
def create_calibration(rig_id: RigId, body: CalibrationCreate, session: SessionDep,
                       _key: WriteKeyDep, estimator: EstimatorDep,
                       response: Response) -> CalibrationPublic:
    """Store the table; rows without a clearance get one computed when the service can."""
    calibration = service.create_calibration(session, rig_id, body, estimator=estimator)
    response.headers["Location"] = f"/rigs/{rig_id}/calibrations/{calibration.id}"
    return _public(calibration, get_rig(session, rig_id).latest_version)


@router.get("/{calibration_id}", summary="Get a throttle equivalence table")
def get_calibration(rig_id: RigId, calibration_id: CalibrationId,
                    session: SessionDep) -> CalibrationPublic:
    """Return the table with its interpolation curve."""
    return _public(service.get_calibration(session, rig_id, calibration_id),
                   get_rig(session, rig_id).latest_version)


@router.patch("/{calibration_id}", summary="Change a throttle equivalence table")
def update_calibration(rig_id: RigId, calibration_id: CalibrationId, body: CalibrationUpdate,
                       session: SessionDep, _key: WriteKeyDep,
                       estimator: EstimatorDep) -> CalibrationPublic:
    """Change the given fields; ``points`` replace every row.  A changed condition
    (component, back-pressure, temperature) without ``points`` corrects the table's
    condition: computed clearances are computed again, given ones stay as given; to move a
    table to another condition, send its points too."""
    calibration = service.update_calibration(session, rig_id, calibration_id, body,
                                             estimator=estimator)
    return _public(calibration, get_rig(session, rig_id).latest_version)


@router.delete("/{calibration_id}", status_code=status.HTTP_204_NO_CONTENT,
               response_class=Response, summary="Delete a throttle equivalence table")
def delete_calibration(rig_id: RigId, calibration_id: CalibrationId, session: SessionDep,
                       _key: AdminKeyDep) -> None:
    """Delete the table and its rows (a key of scope ``admin``)."""
    service.delete_calibration(session, rig_id, calibration_id)


@router.get("/{calibration_id}/clearance",
            summary="Equivalent clearance at given throttle openings")
def clearance_at(
    rig_id: RigId,
    calibration_id: CalibrationId,
    session: SessionDep,
    opening_turns: Annotated[
        list[FiniteFloat],
        Query(min_length=1, max_length=1000,
              description="Throttle openings, repeat the parameter for several [turn]",
              examples=[[0.25]]),
    ],
) -> ClearanceSamples:
    """Interpolate the table's monotone curve (PCHIP) at each opening; no extrapolation."""
    calibration = service.get_calibration(session, rig_id, calibration_id)
    curve = service.curve_of(calibration)
    if curve is None:
        raise InputError(
            f"calibration {calibration_id} has fewer than two known clearances", field="points"
        )
    values = curve(opening_turns, field="opening_turns")
    return ClearanceSamples(
        calibration_id=calibration.id,
        component=calibration.component,
        stale=service.is_stale(calibration, get_rig(session, rig_id).latest_version),
        samples=[ClearanceAt(opening_turns=x, clearance_m=c)
                 for x, c in zip(opening_turns, values, strict=True)],
    )
