"""Pump parameter sets and loss maps."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, File, Form, Path, Query, Response, UploadFile, status

from app.api.deps import PageDep, ReadAccess, SessionDep, WriteKeyDep
from app.schemas.common import ERROR_RESPONSES, MAX_ID
from app.schemas.pumps import (
    PumpBenchForm,
    PumpSetCreate,
    PumpSetKind,
    PumpSetList,
    PumpSetPublic,
    PumpSetUpdate,
)
from app.services import pumps as service
from app.services.pump_bench import MAX_CSV_BYTES, store_bench_parameters

__all__ = ["router"]

# ``{pump_set_id:int}``: only digits reach the id routes, so ``/pump-sets/bench`` is never
# taken for an id whatever the method (a 405 naming POST, not a 422 on the id).
router = APIRouter(prefix="/pump-sets", tags=["pump sets"], dependencies=[ReadAccess],
                   responses=ERROR_RESPONSES)

PumpSetId = Annotated[int, Path(ge=1, le=MAX_ID, description="Pump set identifier [-]",
                                examples=[1])]


@router.get("", summary="List pump parameter sets and loss maps")
def list_pump_sets(
    session: SessionDep,
    page: PageDep,
    rig_id: Annotated[int | None, Query(ge=1, le=MAX_ID,
                                        description="Only sets of this rig [-]",
                                        examples=[1])] = None,
    kind: Annotated[PumpSetKind | None, Query(description="Only sets of this kind [-]",
                                              examples=["loss_map"])] = None,
) -> PumpSetList:
    """Return a page of pump sets, in order of creation."""
    rows, total = service.list_pump_sets(session, limit=page.limit, offset=page.offset,
                                         rig_id=rig_id, kind=kind)
    return PumpSetList(items=[PumpSetPublic.model_validate(r) for r in rows], total=total,
                       limit=page.limit, offset=page.offset)


@router.post("", status_code=status.HTTP_201_CREATED, summary="Store a pump set")
def create_pump_set(body: PumpSetCreate, session: SessionDep, _key: WriteKeyDep,
                    response: Response) -> PumpSetPublic:
    """Store a parameter set or loss map; every quantity carries its unit."""
    pump_set = service.create_pump_set(session, body)
    response.headers["Location"] = f"/pump-sets/{pump_set.id}"
    return PumpSetPublic.model_validate(pump_set)


@router.post("/bench", status_code=status.HTTP_201_CREATED,
             summary="Parameterise a pump from a bench CSV and store the set")
def create_from_bench(
    form: Annotated[PumpBenchForm, Form()],
    file: Annotated[UploadFile, File(
        description="Bench CSV, one row per steady test point, units in the column names "
        "(diagnostics.pump.csvio) [-]",
        examples=["p_in [Pa],p_out [Pa],n [rev/s],theta [degC],q [m^3/s],T [N*m]\n"
                  "0,2e6,10,22,2.3e-5,8.1\n"])],
    session: SessionDep,
    _key: WriteKeyDep,
    response: Response,
) -> PumpSetPublic:
    """Read the ISO 4409 test points, fit paper 000's loss model (D, Cs, Cst; Cv, Cf with
    torque) and store it as a pump parameter set."""
    content = file.file.read(MAX_CSV_BYTES + 1)
    pump_set = store_bench_parameters(session, form, content)
    response.headers["Location"] = f"/pump-sets/{pump_set.id}"
    return PumpSetPublic.model_validate(pump_set)


@router.get("/{pump_set_id:int}", summary="Get a pump set")
def get_pump_set(pump_set_id: PumpSetId, session: SessionDep) -> PumpSetPublic:
    """Return the pump set."""
    return PumpSetPublic.model_validate(service.get_pump_set(session, pump_set_id))


@router.patch("/{pump_set_id:int}", summary="Change a pump set")
def update_pump_set(pump_set_id: PumpSetId, body: PumpSetUpdate, session: SessionDep,
                    _key: WriteKeyDep) -> PumpSetPublic:
    """Change the given fields; ``quantities`` replace all of them."""
    return PumpSetPublic.model_validate(service.update_pump_set(session, pump_set_id, body))


@router.delete("/{pump_set_id:int}", status_code=status.HTTP_204_NO_CONTENT,
               response_class=Response, summary="Delete a pump set")
def delete_pump_set(pump_set_id: PumpSetId, session: SessionDep, _key: WriteKeyDep) -> None:
    """Delete the pump set."""
    service.delete_pump_set(session, pump_set_id)
