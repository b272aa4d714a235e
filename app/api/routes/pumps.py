"""Pump parameter sets and loss maps."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, File, Form, Path, Query, Response, UploadFile, status

from app.api.deps import AdminKeyDep, PageDep, ReadAccess, SessionDep, WriteKeyDep
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

#: Example of a bench CSV: a SIMULATED virtual ISO 4409 run of the stand-in gear pump map
#: (diagnostics.pump.run_virtual_bench, no noise), 4 speeds x 5 pressures at 22 and 60 degC.
_BENCH_EXAMPLE = (
    "p_in [Pa],p_out [Pa],n [rev/s],theta [degC],q [m^3/s],T [N*m]\n"
    "0,2000000,11.9366,22,0.000174385,5.54044\n"
    "0,6000000,11.9366,22,0.000172827,15.5001\n"
    "0,10000000,11.9366,22,0.000171524,25.1256\n"
    "0,14000000,11.9366,22,0.000170467,34.6448\n"
    "0,18000000,11.9366,22,0.000169656,44.2006\n"
    "0,2000000,19.8944,22,0.000291255,5.79641\n"
    "0,6000000,19.8944,22,0.00028943,15.7732\n"
    "0,10000000,19.8944,22,0.000287821,25.4205\n"
    "0,14000000,19.8944,22,0.000286445,34.9629\n"
    "0,18000000,19.8944,22,0.000285313,44.5415\n"
    "0,2000000,27.8521,22,0.000408163,6.07182\n"
    "0,6000000,27.8521,22,0.000406095,16.0675\n"
    "0,10000000,27.8521,22,0.000404171,25.7385\n"
    "0,14000000,27.8521,22,0.000402451,35.3061\n"
    "0,18000000,27.8521,22,0.000400979,44.9092\n"
    "0,2000000,35.8099,22,0.000525124,6.36669\n"
    "0,6000000,35.8099,22,0.000522848,16.3832\n"
    "0,10000000,35.8099,22,0.000520592,26.0797\n"
    "0,14000000,35.8099,22,0.000518498,35.6742\n"
    "0,18000000,35.8099,22,0.000516659,45.3039\n"
    "0,2000000,11.9366,60,0.000173188,5.24319\n"
    "0,6000000,11.9366,60,0.000169945,15.1745\n"
    "0,10000000,11.9366,60,0.000167688,24.7717\n"
    "0,14000000,11.9366,60,0.000166147,34.2626\n"
    "0,18000000,11.9366,60,0.00016505,43.7901\n"
    "0,2000000,19.8944,60,0.000290238,5.28079\n"
    "0,6000000,19.8944,60,0.00028687,15.2084\n"
    "0,10000000,19.8944,60,0.000284285,24.8067\n"
    "0,14000000,19.8944,60,0.000282343,34.3\n"
    "0,18000000,19.8944,60,0.000280855,43.8294\n"
    "0,2000000,27.8521,60,0.000407507,5.3217\n"
    "0,6000000,27.8521,60,0.000404168,15.246\n"
    "0,10000000,27.8521,60,0.000401188,24.8455\n"
    "0,14000000,27.8521,60,0.000398708,34.3416\n"
    "0,18000000,27.8521,60,0.000396717,43.8733\n"
    "0,2000000,35.8099,60,0.000525085,5.3659\n"
    "0,6000000,35.8099,60,0.000521986,15.2871\n"
    "0,10000000,35.8099,60,0.000518519,24.8883\n"
    "0,14000000,35.8099,60,0.000515309,34.3875\n"
    "0,18000000,35.8099,60,0.000512656,43.9218\n"
)

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
        examples=[_BENCH_EXAMPLE])],
    session: SessionDep,
    _key: WriteKeyDep,
    response: Response,
) -> PumpSetPublic:
    """Read the ISO 4409 test points, fit paper 000's loss model (D, Cs, Cst; Cv, Cf with
    torque) and store it as a pump parameter set.  With torque and three speeds or more, the
    set also keeps the sign-checked loss model checked with one speed left out: the test
    points (``points_*``), each point's held-out prediction and the error (``check_flow_S``,
    ``check_torque_S`` [%])."""
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
def delete_pump_set(pump_set_id: PumpSetId, session: SessionDep, _key: AdminKeyDep) -> None:
    """Delete the pump set (a key of scope ``admin``)."""
    service.delete_pump_set(session, pump_set_id)
